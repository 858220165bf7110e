// `portaslam bench --profile-kernels`: the device time of every kernel per timed frame, for the
// backends that time their dispatches (vulkan: timestamp queries; opencl: profiling events).
#pragma once

#include <cstddef>
#include <cstdio>
#include <string>
#include <vector>

#include "porta/backend.hpp"

namespace porta::app {

struct KernelProfileRow {
  std::string title;    ///< the bench row: backend label, resolution, levels, mode
  std::size_t frames = 0;  ///< timed frames the totals cover
  std::vector<KernelTime> kernels;  ///< empty: the backend does not time kernels
};

/// One table per row: kernel, dispatches per frame, device µs per frame, share of the row's
/// device total, host µs per frame; the kernels in first-dispatch order.
void print_kernel_profiles(const std::vector<KernelProfileRow>& rows, std::FILE* out);

/// `[{"kernel": ..., "dispatches_per_frame": ..., "device_us_per_frame": ..., "host_us_per_frame": ...}, ...]`.
std::string kernel_profile_json(const std::vector<KernelTime>& kernels, std::size_t frames);

}  // namespace porta::app
