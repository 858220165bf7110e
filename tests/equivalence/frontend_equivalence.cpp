// Equivalence of the whole pipeline: porta::Frontend on cpu and on the backend under test, mono
// (detect) and stereo (detect_stereo), two frames in a row through the same Frontend so that state
// left over from the first frame (stale counts, lists, descriptors) shows in the second; then the
// same frames again through a Frontend that keeps all of them in flight at once (submit every
// frame, then collect: on cuda each frame on queues of its own, results downloaded asynchronously),
// its images handed over as pinned InputImages that the device reads in place.
#include <algorithm>
#include <sstream>
#include <utility>

#include "equivalence/compare.hpp"
#include "equivalence/harness.hpp"
#include "equivalence/inputs.hpp"
#include "porta/frontend.hpp"

namespace porta::eq {
namespace {

std::string per_level(const std::vector<int>& counts) {
  std::ostringstream o;
  o << "[";
  for (std::size_t i = 0; i < counts.size(); ++i) o << (i ? " " : "") << counts[i];
  o << "]";
  return o.str();
}

FrontendOptions all_in_flight(std::size_t frames) {
  FrontendOptions o;
  o.in_flight = static_cast<int>(std::clamp<std::size_t>(frames, 1, FrontendOptions::kMaxInFlight));
  return o;
}

std::vector<InputImage> input_images(Frontend& frontend, const std::vector<const Image*>& images) {
  std::vector<InputImage> out;
  for (const Image* image : images) {
    out.push_back(frontend.make_input_image());
    out.back().assign(image->view());
  }
  return out;
}

// Frames [0, per_pass) come one at a time, the next per_pass all in flight at once.
std::string frame_name(std::size_t f, std::size_t per_pass) {
  return f < per_pass ? "frame " + std::to_string(f + 1)
                      : "frame " + std::to_string(f - per_pass + 1) + " (all frames in flight)";
}

class FrontendPipeline : public KernelEquivalence {
 protected:
  /// Keypoints, then (only when those agree, as they would be misaligned otherwise) descriptors.
  /// Returns true when both agree.
  bool expect_same_features(const std::string& where, const Features& a, const Features& b) {
    const Sides sides{"cpu", backend_name()};
    const Locator locate = [&](std::size_t i) { return locate_keypoint(a.keypoints, i); };
    if (Mismatch m = compare_keypoints(a.keypoints, b.keypoints, sides, locate)) {
      if (a.keypoints_per_level != b.keypoints_per_level)
        *m += "\n  keypoints per level: cpu " + per_level(a.keypoints_per_level) + ", " + backend_name() +
              " " + per_level(b.keypoints_per_level);
      expect_same(where + ": " + *m + "\n  (descriptors not compared: they belong to different keypoints)");
      return false;
    }
    if (Mismatch m = compare_descriptors(a.descriptors, b.descriptors, sides, locate)) {
      expect_same(where + ": " + *m);
      return false;
    }
    return true;
  }
};

TEST_P(FrontendPipeline, MatchesCpu) {
  const KernelCase& c = GetParam();
  std::vector<const Image*> images;
  for (const auto& name : c.inputs) {
    std::string why;
    images.push_back(input_image(name, why));
    if (images.back() == nullptr) {
      note_input_skip();
      GTEST_SKIP() << why;
    }
  }
  const FrontendSettings& settings = profiles().at(static_cast<std::size_t>(c.profile)).settings;
  const int w = images[0]->width(), h = images[0]->height();

  if (c.stereo) {
    auto out = run_both([&](Backend& b) {
      Frontend frontend(b, settings, w, h);
      std::vector<StereoFeatures> frames;
      for (std::size_t f = 0; f + 1 < images.size(); f += 2)
        frames.push_back(frontend.detect_stereo(images[f]->view(), images[f + 1]->view()));
      Frontend pipelined(b, settings, w, h, all_in_flight(images.size() / 2));
      const std::vector<InputImage> inputs = input_images(pipelined, images);
      for (std::size_t f = 0; f + 1 < images.size(); f += 2) pipelined.submit_stereo(inputs[f], inputs[f + 1]);
      while (pipelined.pending() > 0) frames.push_back(pipelined.collect_stereo());
      return frames;
    });
    if (!out) return;
    auto& [ref, got] = *out;
    if (!got.empty() && !got[0].left.keypoints.empty())
      debug_corrupt(&got[0].left.keypoints[got[0].left.keypoints.size() / 2], sizeof(Keypoint), 0);
    for (std::size_t f = 0; f < ref.size(); ++f) {
      const std::string frame = frame_name(f, ref.size() / 2);
      const bool left_same = expect_same_features(frame + ", left image", ref[f].left, got[f].left);
      const bool right_same = expect_same_features(frame + ", right image", ref[f].right, got[f].right);
      if (!left_same || !right_same) continue;  // matches of different keypoints are not comparable
      const auto m = compare_stereo_matches(
          ref[f].matches, got[f].matches, {"cpu", backend_name()},
          [&](std::size_t i) { return "match of left " + locate_keypoint(ref[f].left.keypoints, i); });
      expect_same(m ? Mismatch(frame + ", stereo matches: " + *m) : m);
    }
  } else {
    auto out = run_both([&](Backend& b) {
      Frontend frontend(b, settings, w, h);
      std::vector<Features> frames;
      for (const Image* image : images) frames.push_back(frontend.detect(image->view()));
      Frontend pipelined(b, settings, w, h, all_in_flight(images.size()));
      const std::vector<InputImage> inputs = input_images(pipelined, images);
      for (const InputImage& input : inputs) pipelined.submit(input);
      while (pipelined.pending() > 0) frames.push_back(pipelined.collect());
      return frames;
    });
    if (!out) return;
    auto& [ref, got] = *out;
    if (!got.empty() && !got[0].keypoints.empty())
      debug_corrupt(&got[0].keypoints[got[0].keypoints.size() / 2], sizeof(Keypoint), 0);
    for (std::size_t f = 0; f < ref.size(); ++f)
      expect_same_features(frame_name(f, ref.size() / 2), ref[f], got[f]);
  }
}

INSTANTIATE_TEST_SUITE_P(Equivalence, FrontendPipeline, ::testing::ValuesIn(cases_for("frontend")),
                         case_name);

}  // namespace
}  // namespace porta::eq
