// See bench_kernels.hpp.
#include "bench_kernels.hpp"

#include <algorithm>
#include <cstdio>
#include <sstream>

namespace porta::app {
namespace {

double per_frame(double total, std::size_t frames) { return frames > 0 ? total / static_cast<double>(frames) : 0.0; }

}  // namespace

void print_kernel_profiles(const std::vector<KernelProfileRow>& rows, std::FILE* out) {
  std::fprintf(out, "\nPer-kernel device time (--profile-kernels: timing every dispatch adds host work, so the\n"
                    "frame times above are not those of an unprofiled run). host us: the host's time issuing\n"
                    "them (opencl: arguments and enqueue; vulkan: recording; rows in brackets: transfers, queue\n"
                    "waits, vulkan's submissions):\n");
  for (const KernelProfileRow& row : rows) {
    std::fprintf(out, "\n%s, %zu frames\n", row.title.c_str(), row.frames);
    if (row.kernels.empty()) {
      std::fprintf(out, "  no per-kernel device timing on this backend (vulkan and opencl time their kernels)\n");
      continue;
    }
    double total_ms = 0.0, host_ms = 0.0;
    int width = 28;  // the name column: the longest name, at least 28
    for (const KernelTime& k : row.kernels) {
      total_ms += k.device_ms;
      host_ms += k.host_ms;
      width = std::max(width, static_cast<int>(k.kernel.size()));
    }
    std::fprintf(out, "  %-*s %12s %14s %7s %10s\n", width, "kernel", "dispatches", "device us", "share", "host us");
    for (const KernelTime& k : row.kernels) {
      std::fprintf(out, "  %-*s %12.1f %14.1f %6.1f%% %10.1f\n", width, k.kernel.c_str(),
                   per_frame(static_cast<double>(k.dispatches), row.frames), per_frame(k.device_ms * 1e3, row.frames),
                   total_ms > 0.0 ? 100.0 * k.device_ms / total_ms : 0.0, per_frame(k.host_ms * 1e3, row.frames));
    }
    std::fprintf(out, "  %-*s %12s %14.1f %7s %10.1f  (per frame; sums of the dispatches, not the frame's wall time)\n",
                 width, "all", "", per_frame(total_ms * 1e3, row.frames), "", per_frame(host_ms * 1e3, row.frames));
  }
}

std::string kernel_profile_json(const std::vector<KernelTime>& kernels, std::size_t frames) {
  std::ostringstream out;
  out << "[";
  for (std::size_t i = 0; i < kernels.size(); ++i) {
    const KernelTime& k = kernels[i];
    // Kernel names are identifiers of our shaders: no character needs escaping.
    out << (i ? ", " : "") << "{\"kernel\": \"" << k.kernel
        << "\", \"dispatches_per_frame\": " << per_frame(static_cast<double>(k.dispatches), frames)
        << ", \"device_us_per_frame\": " << per_frame(k.device_ms * 1e3, frames)
        << ", \"host_us_per_frame\": " << per_frame(k.host_ms * 1e3, frames) << "}";
  }
  out << "]";
  return out.str();
}

}  // namespace porta::app
