#include "features_dump.hpp"

#include <cstdio>

namespace porta::app {

namespace {

void append_keypoints(std::string& out, char tag, const Features& features) {
  static constexpr char kHex[] = "0123456789abcdef";
  for (std::size_t i = 0; i < features.keypoints.size(); ++i) {
    const Keypoint& k = features.keypoints[i];
    char line[96];
    std::snprintf(line, sizeof line, "%c %zu %u %u %u %u %u ", tag, i, unsigned{k.x}, unsigned{k.y},
                  unsigned{k.response}, unsigned{k.level}, unsigned{k.angle_bin});
    out += line;
    if (i < features.descriptors.size()) {
      for (const std::uint8_t byte : features.descriptors[i].bytes) {
        out += kHex[byte >> 4];
        out += kHex[byte & 15];
      }
    } else {
      out += '-';  // no descriptor: a detection-only run
    }
    out += '\n';
  }
}

}  // namespace

std::string features_dump_text(const StereoFeatures& features, int width, int height, bool stereo) {
  std::string out = "portaslam-features-dump 1\n";
  out +=
      "image " + std::to_string(width) + "x" + std::to_string(height) + (stereo ? " stereo\n" : " single\n");
  out += "left keypoints " + std::to_string(features.left.keypoints.size()) + "\n";
  append_keypoints(out, 'L', features.left);
  if (!stereo) return out;
  out += "right keypoints " + std::to_string(features.right.keypoints.size()) + "\n";
  append_keypoints(out, 'R', features.right);
  out += "matches " + std::to_string(features.num_matches()) + " of " +
         std::to_string(features.matches.size()) + "\n";
  for (std::size_t i = 0; i < features.matches.size(); ++i) {
    const StereoMatch& m = features.matches[i];
    out += "M " + std::to_string(i) + " " + std::to_string(m.right_index) + " " +
           std::to_string(m.disparity_q8) + "\n";
  }
  return out;
}

}  // namespace porta::app
