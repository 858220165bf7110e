// `portaslam features --dump FILE`: every keypoint, descriptor and stereo match of a run as text, in
// the frontend's canonical order, so that two runs can be compared byte for byte (`cmp`) and a
// difference read line by line: across backends, thread counts, or builds for other CPUs
// (ci/cross-aarch64.sh compares x86-64 against aarch64 under qemu). No times, no paths, no
// machine names: the same features give the same file.
#pragma once

#include <string>

#include "porta/frontend.hpp"

namespace porta::app {

/// The dump's text (format in docs/USER_GUIDE.md, "features --dump"):
///   portaslam-features-dump 1
///   image WxH stereo|single
///   left keypoints N
///   L index x y response level angle_bin descriptor-as-64-hex-digits      (N lines)
///   right keypoints M                                                       (stereo only)
///   R index ...                                                             (M lines)
///   matches K of N                                                          (stereo only)
///   M index right_index disparity_q8                                        (N lines, -1 -1 = none)
std::string features_dump_text(const StereoFeatures& features, int width, int height, bool stereo);

}  // namespace porta::app
