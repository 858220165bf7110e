// Equivalence of the description kernels (DESIGN.md §3.6, §3.8): orient and orb_describe, on the
// real keypoints the cpu found in each scene. Odd variants put the list's count at byte 8 of its
// buffer and leave spare capacity.
#include "equivalence/compare.hpp"
#include "equivalence/harness.hpp"
#include "equivalence/inputs.hpp"

namespace porta::eq {
namespace {

// ---- orient --------------------------------------------------------------------------------------

class Orient : public KernelEquivalence {};

TEST_P(Orient, MatchesCpu) {
  PORTA_EQ_SCENE_OR_SKIP(s, GetParam().inputs[0], GetParam().profile);
  const auto& t = s->tables;
  // Odd variants start from a garbage angle_bin: orient must overwrite it, not combine with it.
  std::vector<Keypoint> input = s->keypoints;
  if (GetParam().variant % 2)
    for (Keypoint& k : input) k.angle_bin = 0x5A;
  auto out = run_both([&](Backend& b) {
    auto pyramid = upload_vector(b, s->pyramid);
    auto boundaries = upload_vector(b, t.orientation_boundaries);
    DeviceKeypoints list = upload_keypoints(b, input, GetParam().variant);
    b.orient(*pyramid, s->layout, list.list, t.umax, *boundaries, s->settings().orientation_bins);
    return download_vector<Keypoint>(b, *list.items, s->keypoints.size());
  });
  if (!out) return;
  debug_corrupt(out->second.data(), out->second.size() * sizeof(Keypoint),
                out->second.size() / 2 * sizeof(Keypoint) + 7);  // the angle_bin byte
  expect_same(compare_keypoints(out->first, out->second, {"cpu", backend_name()},
                                [&](std::size_t i) { return locate_keypoint(s->keypoints, i); }));
}

INSTANTIATE_TEST_SUITE_P(Equivalence, Orient, ::testing::ValuesIn(cases_for("orient")), case_name);

// ---- orb_describe --------------------------------------------------------------------------------

class OrbDescribe : public KernelEquivalence {};

TEST_P(OrbDescribe, MatchesCpu) {
  PORTA_EQ_SCENE_OR_SKIP(s, GetParam().inputs[0], GetParam().profile);
  const std::size_t n = s->oriented.size();
  auto out = run_both([&](Backend& b) {
    auto blurred = upload_vector(b, s->blurred);
    auto pattern = upload_vector(b, s->tables.orb_pattern);
    DeviceKeypoints list = upload_keypoints(b, s->oriented, GetParam().variant);
    auto descriptors = poisoned(b, static_cast<std::size_t>(list.list.capacity) * sizeof(Descriptor));
    b.orb_describe(*blurred, s->layout, list.list, *pattern, *descriptors);
    return download_vector<Descriptor>(b, *descriptors, n);
  });
  if (!out) return;
  debug_corrupt(out->second.data(), out->second.size() * sizeof(Descriptor), n / 2 * sizeof(Descriptor) + 5);
  expect_same(compare_descriptors(out->first, out->second, {"cpu", backend_name()},
                                  [&](std::size_t i) { return locate_keypoint(s->oriented, i); }));
}

INSTANTIATE_TEST_SUITE_P(Equivalence, OrbDescribe, ::testing::ValuesIn(cases_for("orb_describe")), case_name);

}  // namespace
}  // namespace porta::eq
