// The work split of cull_cells (DESIGN.md §3.4) for each culling variant, shared by the backend
// and the ablation tool (bench/cuda/porta_cuda_ablation.cpp), which times launch_cull_cells alone.
#pragma once

#include "cuda/cuda_backend.hpp"
#include "cuda/kernels.hpp"
#include "porta/layout.hpp"

namespace porta::cuda {

/// The launch description of one cull_cells call over every level (layouts already checked by the
/// caller: at most kMaxLevels levels, fewer than 2^31 cells). `nmax` is MLPT's N_max.
///  - kMlptTewa: MLPT threads per cell, as many cells per 128-thread block as fit (TEWA);
///  - kMlptBlock: the same threads per cell, one cell per 128-thread block;
///  - kLog2Block: one cell per block of the next power of two >= the largest cell's pixels
///    (32..1024 threads), pixels strided over the threads, then a log2 tree in shared memory.
CullLaunch plan_cull(const PyramidLayout& response_layout, const CellLayout& cell_layout, int nmax,
                     CullVariant variant);

}  // namespace porta::cuda
