// Per-kernel device-time totals, as the backends that time their dispatches keep them
// (BackendOptions::profile_kernels, Backend::kernel_times()).
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "porta/backend.hpp"

namespace porta {

class KernelProfile {
 public:
  /// One dispatch of `kernel` that ran `device_ms` on the device.
  void add(const std::string& kernel, double device_ms) {
    KernelTime& t = entry(kernel);
    ++t.dispatches;
    t.device_ms += device_ms;
  }
  /// The host spent `host_ms` issuing one call of `kernel` (counted as a dispatch when `count`:
  /// for rows that have no device time, such as a queue wait).
  void add_host(const std::string& kernel, double host_ms, bool count = false) {
    KernelTime& t = entry(kernel);
    t.host_ms += host_ms;
    if (count) ++t.dispatches;
  }
  /// The totals in first-dispatch order; `reset` starts them again.
  std::vector<KernelTime> take(bool reset) {
    std::vector<KernelTime> out = totals_;
    if (reset) {
      totals_.clear();
      index_.clear();
    }
    return out;
  }

 private:
  KernelTime& entry(const std::string& kernel) {
    auto [it, inserted] = index_.try_emplace(kernel, totals_.size());
    if (inserted) totals_.push_back({kernel, 0, 0.0, 0.0});
    return totals_[it->second];
  }
  std::vector<KernelTime> totals_;
  std::map<std::string, std::size_t> index_;
};

}  // namespace porta
