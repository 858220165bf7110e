// The OpenCL backend (OpenCL 1.2): one context on one device with kQueues in-order command queues
// (the HAL's queues: queue_wait() is a marker event one queue's barrier waits for; asynchronous
// transfers are non-blocking reads and writes from pinned, mapped host buffers); each source of
// shaders/opencl (with common.cl in front) is one program, built on first use from the embedded
// text or loaded from the on-disk binary cache; the kernel contracts of DESIGN.md §3 are
// dispatched from *_kernels.cpp. Queues, memory and transfers are in cl_queues.cpp.
#pragma once

#include <CL/cl.h>

#include <array>
#include <chrono>
#include <map>
#include <memory>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "porta/backend.hpp"
#include "porta/kernel_checks.hpp"
#include "porta/kernel_profile.hpp"
#include "porta/registry.hpp"

namespace porta::opencl {

/// One device as the selection sees it.
struct DeviceEntry {
  cl_platform_id platform = nullptr;
  cl_device_id device = nullptr;
  std::string platform_name;
  std::string device_name;
  bool is_gpu = false;
  std::string label() const { return platform_name + ": " + device_name; }
};

/// Every device of every platform, in platform then device order. Empty when no ICD is installed.
std::vector<DeviceEntry> enumerate_devices();

class OpenClBuffer final : public Buffer {
 public:
  OpenClBuffer(cl_mem mem, std::size_t bytes) : Buffer(bytes), mem_(mem) {}
  ~OpenClBuffer() override;
  cl_mem mem() const { return mem_; }

 private:
  cl_mem mem_;
};

inline cl_mem mem_of(const Buffer& b) { return static_cast<const OpenClBuffer&>(b).mem(); }

/// Launch geometry: `global` work items per dimension (rounded up to `local` when `local` is set).
struct Range {
  std::size_t global[2] = {1, 1};
  std::size_t local[2] = {0, 0};  ///< 0 = let the driver choose
  int dims = 1;
  static Range linear(std::size_t n, std::size_t local = 0) { return {{n, 1}, {local, 0}, 1}; }
  static Range grid(std::size_t x, std::size_t y) { return {{x, y}, {0, 0}, 2}; }
  /// One work-group of kTileW x kTileH per tile (PORTA_TILE_OF in common.cl); `tiles` > 0.
  static Range tiles(std::size_t tiles);
};

class OpenClBackend final : public Backend {
 public:
  /// Selects the device by options.device, else $PORTA_OPENCL_DEVICE, else the first GPU, else the
  /// first device: an index into enumerate_devices() or a case-insensitive substring of its label.
  explicit OpenClBackend(const BackendOptions& options = {});
  ~OpenClBackend() override;

  std::string name() const override { return "opencl"; }
  std::string device_name() const override { return device_.label(); }

  std::unique_ptr<Buffer> allocate(std::size_t bytes) override;
  void upload(Buffer& dst, std::size_t dst_offset, const void* src, std::size_t bytes) override;
  void download(const Buffer& src, std::size_t src_offset, void* dst, std::size_t bytes) override;
  void fill(Buffer& dst, std::size_t offset, std::size_t bytes, std::uint8_t value) override;
  void synchronize() override;
  void flush() override;
  std::vector<KernelTime> kernel_times(bool reset) override;

  static constexpr int kQueues = 8;
  /// kQueues, or $PORTA_OPENCL_QUEUES (1 to kQueues).
  int queue_count() const override { return queue_count_; }
  /// allocate_host: pinned memory (CL_MEM_ALLOC_HOST_PTR, mapped for its whole life);
  /// upload_async / download_async: non-blocking writes and reads on the current queue.
  PORTA_BACKEND_QUEUE_OVERRIDES;

  PORTA_BACKEND_KERNEL_OVERRIDES;
  /// With fused_detect(): FAST, culling and PFA's step A in one launch, PFA's other steps and the
  /// compaction in one more (above 512 cells with pfa_decide between them); otherwise the four
  /// kernels' launches.
  void detect_keypoints(const Buffer& pyramid, const PyramidLayout& layout, const Buffer& lut, Buffer& responses,
                        const PyramidLayout& response_layout, const FastParams& fast, const CellLayout& cell_layout,
                        Buffer& cells, const PfaParams* pfa, DeviceList out) override;

  // ---- for the kernel files ----
  /// Kernel `kernel_name` of program `program` (a file of shaders/opencl without ".cl"), created on
  /// first use; the program is built then too. Both names must outlive the backend (string
  /// literals): later calls find the kernel by their addresses.
  cl_kernel kernel(const char* program, const char* kernel_name);
  /// Sets the arguments in order (a Buffer& passes its cl_mem, anything else by value) and enqueues.
  template <typename... Args>
  void launch(const char* program, const char* kernel_name, const Range& range, const Args&... args) {
    const Clock::time_point start = profile_kernels_ ? Clock::now() : Clock::time_point{};
    cl_kernel k = kernel(program, kernel_name);
    cl_uint index = 0;
    (set_arg(k, kernel_name, index++, args), ...);
    enqueue(k, kernel_name, range, start);
  }
  /// Scratch device memory that lives as long as the backend, grown on demand (never shrunk); one
  /// per queue: queues never share scratch memory.
  Buffer& scratch(const std::string& name, std::size_t bytes);
  /// The current queue, to enqueue on: the next flush() flushes it.
  cl_command_queue queue() {
    mark_used(current_);
    return queues_[static_cast<std::size_t>(current_)];
  }
  /// Kernels with a work-group per item (cull_cells_group, stereo_match_candidates_group) instead
  /// of a work-item, per 32 x 8 tile of all levels with local memory (fast_tiled, blur_tiled: one
  /// launch where the blur had two), PFA and compaction in one work-group (pfa_group,
  /// compact_group) instead of three launches each: on a GPU that runs groups of 256, where they
  /// pay; a CPU device (PoCL) runs work-items as loops, and there they are slower. $PORTA_OPENCL_WORK_GROUPS=on or off overrides (the equivalence suite
  /// runs both kinds on PoCL). The bytes are the same either way.
  bool work_groups() const { return work_groups_; }
  /// Whether detect_keypoints fuses its kernels (fast_cull_group, pfa_compact_group): where
  /// work_groups() is on; $PORTA_OPENCL_FUSED_DETECT=on or off overrides.
  bool fused_detect() const { return fused_detect_; }
  /// With fused_detect(): whether fast_cull_group also does PFA's step A, pfa_compact_group the
  /// rest (with pfa_decide between them above kPfaCompactGroupCells cells); or, as before that,
  /// PFA runs whole in pfa_compact_group up to that many cells and as pfa_filter above
  /// ($PORTA_OPENCL_PFA_IN_CULL=on, the default, or off). The same bytes either way.
  bool pfa_in_cull() const { return pfa_in_cull_; }
  /// Whether build_pyramid builds levels 1..m in one launch (build_pyramid_fused): by default
  /// where work_groups() is on; $PORTA_OPENCL_FUSED_PYRAMID=on or off overrides.
  bool fused_pyramid() const { return fused_pyramid_; }
  /// CL_DEVICE_MAX_WORK_GROUP_SIZE.
  std::size_t max_work_group() const { return max_work_group_; }

 private:
  template <typename T>
  void set_arg(cl_kernel k, const char* kernel_name, cl_uint index, const T& value) {
    if constexpr (std::is_base_of_v<Buffer, T>) {
      const cl_mem m = mem_of(value);
      set_arg_raw(k, kernel_name, index, sizeof(cl_mem), &m);
    } else {
      static_assert(std::is_trivially_copyable_v<T>);
      set_arg_raw(k, kernel_name, index, sizeof(T), &value);
    }
  }
  using Clock = std::chrono::steady_clock;
  void set_arg_raw(cl_kernel k, const char* kernel_name, cl_uint index, std::size_t size, const void* value);
  /// Enqueues `k`; `start` is when its launch() began (host time, when profiling).
  void enqueue(cl_kernel k, const char* kernel_name, const Range& range, Clock::time_point start);
  /// BackendOptions::profile_kernels: where a command's event goes (nullptr when not profiling).
  cl_event* event_slot(cl_event& event) { return profile_kernels_ ? &event : nullptr; }
  /// BackendOptions::profile_kernels: the host's time for `name` since `start`, and its event (if
  /// any) to read the device time from once its queue has finished.
  void note_command(const char* name, cl_event event, Clock::time_point start);
  /// Adds the timed dispatches of `queue` (every queue when -1), which have finished, to profile_
  /// and releases their events.
  void read_timed_events(int queue);
  void finish_all();
  cl_program program(const char* name);
  cl_program build_program(const std::string& name, const std::string& source);

  DeviceEntry device_;
  cl_context context_ = nullptr;
  std::array<cl_command_queue, kQueues> queues_{};
  int queue_count_ = 1;
  int current_ = 0;
  /// Queues given commands since their last flush (unflushed_) or finish (unfinished_): flush() and
  /// finish_all() call the driver for those only (a clFlush or clFinish costs NVIDIA's driver a
  /// few microseconds even on an idle queue, and a frame uses one or two of kQueues).
  std::array<bool, kQueues> unflushed_{};
  std::array<bool, kQueues> unfinished_{};
  void mark_used(int queue) {
    unflushed_[static_cast<std::size_t>(queue)] = true;
    unfinished_[static_cast<std::size_t>(queue)] = true;
  }
  std::map<std::string, cl_program> programs_;
  std::map<std::string, cl_kernel> kernels_;  // owns them; key: "program/kernel"
  std::map<std::pair<const char*, const char*>, cl_kernel> kernels_by_address_;  // the same, by the names' addresses
  std::map<std::pair<int, std::string>, std::unique_ptr<Buffer>> scratch_;  // key: queue, name
  /// How many levels build_pyramid_fused builds in one launch: 32 x 8 tiles, 8 KiB regions (its
  /// PORTA_REGION_WORDS * 4).
  checks::FusedPyramidLevels fused_levels_{32, 8, 8192};
  /// Whether build_pyramid fuses levels ($PORTA_OPENCL_FUSED_PYRAMID=on|off; by default where the
  /// work-group kernels run, i.e. on GPUs).
  bool fused_pyramid_ = false;
  bool profile_kernels_ = false;
  bool work_groups_ = false;
  bool fused_detect_ = false;
  bool pfa_in_cull_ = true;
  std::size_t max_work_group_ = 0;
  struct TimedDispatch {
    int queue;
    std::string kernel;
    cl_event event;
  };
  std::vector<TimedDispatch> timed_;  ///< dispatches whose queue has not been finished since
  KernelProfile profile_;
};

}  // namespace porta::opencl
