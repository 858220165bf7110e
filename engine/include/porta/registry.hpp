// Run-time registry of compute backends (DESIGN.md §4): lists what this build has and what can
// run on this machine, and creates a backend by name with a clear error when it cannot.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "porta/backend.hpp"

namespace porta {

struct BackendOptions {
  /// Device to use: an index ("0") or a case-insensitive substring of the device name; empty =
  /// the backend's default (its environment variable, e.g. PORTA_OPENCL_DEVICE, then the first).
  std::string device;
  /// cpu backend: worker threads, 0 = all hardware threads.
  int threads = 0;
  /// vulkan and opencl: time every dispatch on the device (Vulkan timestamp queries, OpenCL
  /// profiling events), read with Backend::kernel_times(). It costs a little per dispatch, so
  /// leave it off for timing whole frames. The cpu and cuda backends ignore it.
  bool profile_kernels = false;
};

struct BackendInfo {
  std::string name;
  bool compiled = false;   ///< built into this binary
  bool available = false;  ///< a usable device was found
  std::string detail;      ///< the devices found, or why the backend is unavailable
};

using BackendFactory = std::function<std::unique_ptr<Backend>(const BackendOptions&)>;
using BackendProbe = std::function<BackendInfo()>;

class BackendRegistry {
 public:
  /// The registry with every backend of this build registered.
  static BackendRegistry& instance();

  void add(std::string name, BackendProbe probe, BackendFactory factory);
  /// Every known backend, built or not, in the order cpu, cuda, vulkan, opencl.
  std::vector<BackendInfo> list() const;
  /// Creates the named backend; throws BackendError naming what is missing.
  std::unique_ptr<Backend> create(const std::string& name, const BackendOptions& options = {}) const;

 private:
  struct Entry {
    std::string name;
    BackendProbe probe;
    BackendFactory factory;
  };
  std::vector<Entry> entries_;
};

/// Names every backend the project knows, compiled or not.
const std::vector<std::string>& known_backend_names();

}  // namespace porta
