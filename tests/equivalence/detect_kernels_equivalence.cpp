// Equivalence of the detection kernels (DESIGN.md §3.3-§3.5): fast_crf, cull_cells, pfa_filter,
// compact_keypoints. Each kernel gets the cpu-made output of the stage before it as input.
#include <algorithm>
#include <cstring>

#include "equivalence/compare.hpp"
#include "equivalence/harness.hpp"
#include "equivalence/inputs.hpp"

namespace porta::eq {
namespace {

Locator cells_of(const Scene& s) {
  return [&s](std::size_t i) { return s.locate_cell(i); };
}

/// The index of a non-empty record near the middle (for PORTA_EQUIVALENCE_CORRUPT), else the middle.
std::size_t middle_keypoint(const std::vector<Keypoint>& v) {
  for (std::size_t i = v.size() / 2; i < v.size(); ++i)
    if (v[i].response != 0) return i;
  return v.size() / 2;
}

// ---- fast_crf ------------------------------------------------------------------------------------

class FastCrf : public KernelEquivalence {};

TEST_P(FastCrf, MatchesCpu) {
  PORTA_EQ_SCENE_OR_SKIP(s, GetParam().inputs[0], GetParam().profile);
  const auto total = static_cast<std::size_t>(s->response_layout.total_bytes);
  const FastParams params{s->settings().fast_threshold, s->settings().edge};
  auto out = run_both([&](Backend& b) {
    auto pyramid = upload_vector(b, s->pyramid);
    auto lut = upload_vector(b, s->tables.fast_lut);
    auto responses = poisoned(b, total);
    b.fast_crf(*pyramid, s->layout, *lut, *responses, s->response_layout, params);
    return download_bytes(b, *responses, total);
  });
  if (!out) return;
  const Plane& l0 = s->response_layout.levels[0];
  debug_corrupt(
      out->second.data(), out->second.size(),
      static_cast<std::size_t>(l0.offset_bytes +
                               (static_cast<std::int64_t>(l0.height / 2) * l0.pitch + l0.width / 2) * 2));
  expect_same(compare_planes(out->first, out->second, s->response_layout.levels, 2, {"cpu", backend_name()}));
}

INSTANTIATE_TEST_SUITE_P(Equivalence, FastCrf, ::testing::ValuesIn(cases_for("fast_crf")), case_name);

// ---- cull_cells ----------------------------------------------------------------------------------

class CullCells : public KernelEquivalence {};

TEST_P(CullCells, MatchesCpu) {
  PORTA_EQ_SCENE_OR_SKIP(s, GetParam().inputs[0], GetParam().profile);
  const auto total_cells = static_cast<std::size_t>(s->tables.cells.total_cells);
  auto out = run_both([&](Backend& b) {
    auto responses = upload_vector(b, s->responses);
    auto cells = poisoned(b, total_cells * sizeof(Keypoint));
    b.cull_cells(*responses, s->response_layout, s->tables.cells, *cells);
    return download_vector<Keypoint>(b, *cells, total_cells);
  });
  if (!out) return;
  debug_corrupt(out->second.data(), out->second.size() * sizeof(Keypoint),
                middle_keypoint(out->first) * sizeof(Keypoint));
  expect_same(compare_keypoints(out->first, out->second, {"cpu", backend_name()}, cells_of(*s)));
}

INSTANTIATE_TEST_SUITE_P(Equivalence, CullCells, ::testing::ValuesIn(cases_for("cull_cells")), case_name);

// ---- pfa_filter ----------------------------------------------------------------------------------

class PfaFilter : public KernelEquivalence {};

TEST_P(PfaFilter, MatchesCpu) {
  // Run whatever the profile's pfa flag (its window is used): the flag only matters to compaction.
  PORTA_EQ_SCENE_OR_SKIP(s, GetParam().inputs[0], GetParam().profile);
  const auto total_cells = static_cast<std::size_t>(s->tables.cells.total_cells);
  const Plane& l0 = s->layout.levels[0];
  const PfaParams params{s->tables.scales_q16, l0.width, l0.height, s->settings().pfa_window};
  auto out = run_both([&](Backend& b) {
    auto cells = upload_vector(b, s->cells);
    b.pfa_filter(*cells, s->tables.cells, params);
    return download_vector<Keypoint>(b, *cells, total_cells);
  });
  if (!out) return;
  debug_corrupt(out->second.data(), out->second.size() * sizeof(Keypoint),
                middle_keypoint(out->first) * sizeof(Keypoint));
  expect_same(compare_keypoints(out->first, out->second, {"cpu", backend_name()}, cells_of(*s)));
}

INSTANTIATE_TEST_SUITE_P(Equivalence, PfaFilter, ::testing::ValuesIn(cases_for("pfa_filter")), case_name);

// ---- compact_keypoints ---------------------------------------------------------------------------

class CompactKeypoints : public KernelEquivalence {};

TEST_P(CompactKeypoints, MatchesCpu) {
  PORTA_EQ_SCENE_OR_SKIP(s, GetParam().inputs[0], GetParam().profile);
  const int total_cells = s->tables.cells.total_cells;
  const std::vector<Keypoint>& dense = s->settings().pfa ? s->filtered : s->cells;
  struct Result {
    std::uint32_t count;
    std::vector<Keypoint> items;
  };
  auto out = run_both([&](Backend& b) {
    auto cells = upload_vector(b, dense);
    DeviceKeypoints list =
        empty_keypoints(b, total_cells + (GetParam().variant % 2 ? 5 : 0), GetParam().variant);
    b.compact_keypoints(*cells, total_cells, list.list);
    const std::uint32_t count = download_count(b, list.list);
    const auto readable = std::min<std::uint32_t>(count, static_cast<std::uint32_t>(list.list.capacity));
    return Result{count, download_vector<Keypoint>(b, *list.items, readable)};
  });
  if (!out) return;
  auto& [ref, got] = *out;
  debug_corrupt(got.items.data(), got.items.size() * sizeof(Keypoint),
                got.items.size() / 2 * sizeof(Keypoint));
  // Unequal counts show as lists of unequal length below; a count past the capacity would not.
  if (ref.items.size() == got.items.size())
    expect_same(compare_count("the keypoint count", ref.count, got.count, {"cpu", backend_name()}));
  expect_same(compare_keypoints(ref.items, got.items, {"cpu", backend_name()},
                                [&](std::size_t i) { return locate_keypoint(ref.items, i); }));
}

INSTANTIATE_TEST_SUITE_P(Equivalence, CompactKeypoints, ::testing::ValuesIn(cases_for("compact_keypoints")),
                         case_name);

}  // namespace
}  // namespace porta::eq
