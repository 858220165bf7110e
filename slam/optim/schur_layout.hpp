// The index structure of one stage of the Schur solver (private to porta_optim; see
// schur_solver.hpp): the active observations grouped by point, the same observations listed per
// free keyframe, and every product the reduced camera system takes from a point, listed per 6x6
// block of it. Built once per stage; each list keeps the order in which one sequential sweep over
// the points meets its entries, so that work split by point, by keyframe or by block adds the same
// numbers in the same order as that sweep, on any number of threads.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "porta/slam/optim/local_bundle_adjustment.hpp"

namespace porta::slam::optim::detail {

struct SchurLayout {
  // By point. Observation slots a (0 .. observations.size()) are the active observations in point
  // order, then input order; every per-observation array below is indexed by slot.
  std::vector<std::size_t> points;        ///< points with an active observation, ascending
  std::vector<std::size_t> group_begin;   ///< per point, into the slots; points.size() + 1 entries
  std::vector<std::size_t> observations;  ///< per slot: its index in the input
  std::vector<std::uint32_t> point_of;    ///< per slot: its point's place in `points`
  std::vector<int> free_of;  ///< per slot: its keyframe's place among the free ones, -1 when fixed

  // By free keyframe: the slots of its observations, ascending.
  std::vector<int> free_index;  ///< per keyframe: its place among the free ones, -1 when fixed
  int free_keyframes = 0;
  std::vector<std::size_t> keyframe_begin;  ///< free_keyframes + 1 entries
  std::vector<std::uint32_t> keyframe_slots;
  std::vector<std::uint32_t> keyframe_position;  ///< per free slot: its place in keyframe_slots

  // By block of the reduced camera system (upper triangle: row <= col, in free keyframes). A term
  // subtracts Y[x] W[y]^T from its block (and Y[y] W[x]^T too when `both`: two observations of one
  // point in one keyframe), where Y = W V^-1 of the slot's point.
  struct Term {
    std::uint32_t x = 0, y = 0;
    bool both = false;
  };
  struct Block {
    int row = 0, col = 0;
  };
  std::vector<Block> blocks;
  std::vector<std::size_t> block_begin;  ///< blocks.size() + 1 entries
  std::vector<Term> terms;
};

/// The layout of the observations flagged in `active` over `num_keyframes` keyframes (those with
/// `pose_fixed` set are held) and `num_points` points. The per-keyframe and per-block lists serve
/// only work split over threads: without `split` they are left empty (a single sweep by point
/// needs neither, and listing every term costs a third of the sweep's own time).
SchurLayout make_schur_layout(std::span<const BaObservation> observations, const std::vector<bool>& active,
                              const std::vector<bool>& pose_fixed, std::size_t num_points, bool split);

}  // namespace porta::slam::optim::detail
