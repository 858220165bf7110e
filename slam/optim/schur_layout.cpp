// The Schur solver's index structure; see schur_layout.hpp.
#include "schur_layout.hpp"

#include <limits>
#include <stdexcept>
#include <string>

namespace porta::slam::optim::detail {
namespace {

/// Calls fn(x, y, both, row, col) for every product a point adds to the reduced camera system, in
/// the order of a sweep over the points, each point's free observations in slot order, each with
/// itself and then with the ones after it.
template <typename Fn>
void for_each_term(const SchurLayout& layout, Fn&& fn) {
  for (std::size_t j = 0; j < layout.points.size(); ++j) {
    const std::size_t end = layout.group_begin[j + 1];
    for (std::size_t a = layout.group_begin[j]; a < end; ++a) {
      const int fa = layout.free_of[a];
      if (fa < 0) continue;
      const auto x = static_cast<std::uint32_t>(a);
      fn(x, x, false, fa, fa);
      for (std::size_t c = a + 1; c < end; ++c) {
        const int fc = layout.free_of[c];
        if (fc < 0) continue;
        const auto y = static_cast<std::uint32_t>(c);
        if (fa < fc) {
          fn(x, y, false, fa, fc);
        } else if (fa > fc) {
          fn(y, x, false, fc, fa);
        } else {
          fn(x, y, true, fa, fa);
        }
      }
    }
  }
}

}  // namespace

SchurLayout make_schur_layout(std::span<const BaObservation> observations, const std::vector<bool>& active,
                              const std::vector<bool>& pose_fixed, std::size_t num_points, bool split) {
  if (observations.size() > std::numeric_limits<std::uint32_t>::max()) {
    throw std::invalid_argument("local_bundle_adjustment: " + std::to_string(observations.size()) +
                                " observations; the schur solver takes at most 2^32 - 1");
  }
  SchurLayout layout;
  const std::size_t num_keyframes = pose_fixed.size();
  layout.free_index.assign(num_keyframes, -1);
  for (std::size_t k = 0; k < num_keyframes; ++k) {
    if (!pose_fixed[k]) layout.free_index[k] = layout.free_keyframes++;
  }

  // By point.
  std::vector<std::size_t> count(num_points, 0);
  for (std::size_t i = 0; i < observations.size(); ++i) {
    if (active[i]) ++count[observations[i].point];
  }
  std::vector<std::size_t> start(num_points, 0);
  layout.group_begin.push_back(0);
  for (std::size_t p = 0; p < num_points; ++p) {
    if (count[p] == 0) continue;
    start[p] = layout.group_begin.back();
    layout.points.push_back(p);
    layout.group_begin.push_back(start[p] + count[p]);
  }
  const std::size_t slots = layout.group_begin.back();
  layout.observations.resize(slots);
  for (std::size_t i = 0; i < observations.size(); ++i) {
    if (active[i]) layout.observations[start[observations[i].point]++] = i;
  }
  layout.point_of.resize(slots);
  layout.free_of.resize(slots);
  for (std::size_t j = 0; j < layout.points.size(); ++j) {
    for (std::size_t a = layout.group_begin[j]; a < layout.group_begin[j + 1]; ++a) {
      layout.point_of[a] = static_cast<std::uint32_t>(j);
      layout.free_of[a] = layout.free_index[observations[layout.observations[a]].keyframe];
    }
  }

  if (!split) return layout;

  // By free keyframe (a counting sort of the slots, which keeps them ascending).
  const auto n_free = static_cast<std::size_t>(layout.free_keyframes);
  layout.keyframe_begin.assign(n_free + 1, 0);
  for (std::size_t a = 0; a < slots; ++a) {
    if (layout.free_of[a] >= 0) ++layout.keyframe_begin[static_cast<std::size_t>(layout.free_of[a]) + 1];
  }
  for (std::size_t f = 0; f < n_free; ++f) layout.keyframe_begin[f + 1] += layout.keyframe_begin[f];
  layout.keyframe_slots.resize(layout.keyframe_begin.back());
  layout.keyframe_position.assign(slots, 0);
  {
    std::vector<std::size_t> next(layout.keyframe_begin.begin(), layout.keyframe_begin.end() - 1);
    for (std::size_t a = 0; a < slots; ++a) {
      if (layout.free_of[a] < 0) continue;
      const std::size_t position = next[static_cast<std::size_t>(layout.free_of[a])]++;
      layout.keyframe_slots[position] = static_cast<std::uint32_t>(a);
      layout.keyframe_position[a] = static_cast<std::uint32_t>(position);
    }
  }

  // By block: number the blocks that receive a term in row-major order, then place the terms
  // (a counting sort again, which keeps each block's terms in sweep order).
  std::vector<std::size_t> block_of(n_free * n_free, 0);  // id + 1; 0 = no term
  std::vector<std::size_t> block_count;
  for_each_term(layout, [&](std::uint32_t, std::uint32_t, bool, int row, int col) {
    block_of[static_cast<std::size_t>(row) * n_free + static_cast<std::size_t>(col)] = 1;
  });
  for (std::size_t row = 0; row < n_free; ++row) {
    for (std::size_t col = row; col < n_free; ++col) {
      std::size_t& id = block_of[row * n_free + col];
      if (id == 0) continue;
      layout.blocks.push_back({static_cast<int>(row), static_cast<int>(col)});
      id = layout.blocks.size();
    }
  }
  layout.block_begin.assign(layout.blocks.size() + 1, 0);
  for_each_term(layout, [&](std::uint32_t, std::uint32_t, bool, int row, int col) {
    ++layout.block_begin[block_of[static_cast<std::size_t>(row) * n_free + static_cast<std::size_t>(col)]];
  });
  for (std::size_t b = 0; b < layout.blocks.size(); ++b) layout.block_begin[b + 1] += layout.block_begin[b];
  layout.terms.resize(layout.block_begin.back());
  std::vector<std::size_t> next(layout.block_begin.begin(), layout.block_begin.end() - 1);
  for_each_term(layout, [&](std::uint32_t x, std::uint32_t y, bool both, int row, int col) {
    const std::size_t id =
        block_of[static_cast<std::size_t>(row) * n_free + static_cast<std::size_t>(col)] - 1;
    layout.terms[next[id]++] = {x, y, both};
  });
  return layout;
}

}  // namespace porta::slam::optim::detail
