// The hardware-abstraction layer: the one interface every compute backend implements
// (DESIGN.md §4). Nothing here names a CUDA, Vulkan or OpenCL type.
//
// Kernels work on device `Buffer`s laid out as described by the structs of layout.hpp; their
// meaning is defined by DESIGN.md §3 and by the cpu backend. Every kernel call is asynchronous
// with respect to the host until `synchronize()` or a `download()`.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "porta/keypoint.hpp"
#include "porta/layout.hpp"

namespace porta {

class Backend;
class HostBuffer;

/// Raised for a failing device call or an unusable backend; the message names the backend, the
/// call, the error code and its meaning.
class BackendError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Device memory owned by one backend. Movable through unique_ptr only; never copied.
class Buffer {
 public:
  virtual ~Buffer() = default;
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;

  std::size_t size_bytes() const { return size_bytes_; }

 protected:
  explicit Buffer(std::size_t size_bytes) : size_bytes_(size_bytes) {}

 private:
  std::size_t size_bytes_;
};

/// Host memory made by one backend for its asynchronous transfers (Backend::allocate_host).
class HostBuffer {
 public:
  virtual ~HostBuffer() = default;
  HostBuffer(const HostBuffer&) = delete;
  HostBuffer& operator=(const HostBuffer&) = delete;

  std::uint8_t* data() { return data_; }
  const std::uint8_t* data() const { return data_; }
  std::size_t size_bytes() const { return size_bytes_; }

 protected:
  HostBuffer(std::uint8_t* data, std::size_t size_bytes) : data_(data), size_bytes_(size_bytes) {}

 private:
  std::uint8_t* data_;
  std::size_t size_bytes_;
};

/// Throws BackendError ("<backend>: <call>: range ... is outside the host buffer of N bytes") when
/// [offset, offset + bytes) does not fit in `buffer`.
void check_host_range(const HostBuffer& buffer, std::size_t offset, std::size_t bytes, const std::string& backend,
                      const char* call);

// ---- Kernel parameters (small, passed by value with each call) -----------------------------------

/// A list of records in a buffer whose length lives on the device, in a uint32 at
/// `count_offset_bytes` of `count`; at most `capacity` records start at byte 0 of `items`.
struct DeviceList {
  Buffer* items = nullptr;
  Buffer* count = nullptr;
  std::int64_t count_offset_bytes = 0;
  int capacity = 0;
};
struct ConstDeviceList {
  const Buffer* items = nullptr;
  const Buffer* count = nullptr;
  std::int64_t count_offset_bytes = 0;
  int capacity = 0;
  ConstDeviceList() = default;
  ConstDeviceList(const DeviceList& l)  // NOLINT(google-explicit-constructor): a list is readable
      : items(l.items), count(l.count), count_offset_bytes(l.count_offset_bytes), capacity(l.capacity) {}
};

struct FastParams {
  int threshold = 20;  ///< epsilon
  int edge = 19;       ///< pixels closer than this to a level's border get response 0
};

struct PfaParams {
  std::vector<std::int32_t> scales_q16;  ///< S[n] per level
  int level0_width = 0;
  int level0_height = 0;
  int window = 3;  ///< q
};

struct StereoParams {
  std::vector<std::int32_t> scales_q16;        ///< S[n] per level
  std::vector<std::int32_t> row_radius_q8;     ///< per right-keypoint level
  int min_disparity_q8 = 0;
  int max_disparity_q8 = 128 * 256;
  int max_hamming = 75;  ///< best distance must be strictly below
};

/// Device time of one kernel, summed over its dispatches (BackendOptions::profile_kernels), and the
/// host's time issuing them: opencl, setting the arguments and enqueueing (transfers and queue
/// waits have rows of their own); vulkan, recording them into the batch (its submissions are the
/// row "(submit)", host time only).
struct KernelTime {
  std::string kernel;
  std::uint64_t dispatches = 0;
  double device_ms = 0.0;
  double host_ms = 0.0;
};

// ---- The interface -------------------------------------------------------------------------------

class Backend {
 public:
  virtual ~Backend() = default;
  Backend() = default;
  Backend(const Backend&) = delete;
  Backend& operator=(const Backend&) = delete;

  /// "cpu", "cuda", "vulkan" or "opencl".
  virtual std::string name() const = 0;
  /// The device in words, e.g. "NVIDIA H100 80GB HBM3" or "cpu (2 threads)".
  virtual std::string device_name() const = 0;

  // Memory. Buffers are zero-filled on allocation.
  virtual std::unique_ptr<Buffer> allocate(std::size_t bytes) = 0;
  virtual void upload(Buffer& dst, std::size_t dst_offset, const void* src, std::size_t bytes) = 0;
  virtual void download(const Buffer& src, std::size_t src_offset, void* dst, std::size_t bytes) = 0;
  /// Sets `bytes` bytes at `offset` to `value`.
  virtual void fill(Buffer& dst, std::size_t offset, std::size_t bytes, std::uint8_t value) = 0;
  /// Waits for all work submitted so far.
  virtual void synchronize() = 0;
  /// Starts the work given so far, on every queue, without waiting for it. Backends that gather
  /// work into batches (vulkan) or hold it in the driver (opencl) may otherwise keep it until a
  /// wait: finish_queue(), synchronize(), a download, or a queue_wait() that needs it. The cpu and
  /// cuda backends start work at once and do nothing here.
  virtual void flush() {}
  /// True when device buffers are host memory (no copy is needed to read them on the host).
  virtual bool host_visible() const { return false; }
  /// Device time per kernel since the backend was made or since the last call with `reset`, in
  /// the order the kernels were first dispatched; waits for the work submitted so far. Empty
  /// unless the backend was made with BackendOptions::profile_kernels and times kernels (vulkan,
  /// opencl).
  virtual std::vector<KernelTime> kernel_times(bool reset) {
    (void)reset;
    return {};
  }

  // ---- Queues and asynchronous transfers (DESIGN.md §4) -------------------------------------------
  //
  // A backend has queue_count() independent queues of work. Calls after `use_queue(q)` go to queue
  // q and run in the order they were made; work on different queues may run at the same time and
  // in any order, so work on one queue sees another queue's results only after `queue_wait`, a
  // `finish_queue` of that queue, or `synchronize()`. Memory allocated and uploads made before
  // a synchronize() are visible to every queue. Backends with one queue ignore use_queue() and
  // queue_wait(): everything runs in call order there.

  /// How many queues use_queue() accepts (1 for a backend that runs everything in order).
  virtual int queue_count() const { return 1; }
  /// Sends later calls to queue `queue` (0 <= queue < queue_count(); BackendError otherwise).
  virtual void use_queue(int queue) { check_queue_index(queue, "use_queue"); }
  /// Later work on the current queue waits for everything submitted to queue `other` so far.
  virtual void queue_wait(int other) { check_queue_index(other, "queue_wait"); }
  /// Waits on the host until everything submitted to `queue` has run, asynchronous downloads into
  /// host buffers included. Errors of that work surface here.
  virtual void finish_queue(int queue) {
    check_queue_index(queue, "finish_queue");
    synchronize();
  }

  /// Host memory for asynchronous transfers: page-locked where that lets the device copy without
  /// the host (cuda), plain memory elsewhere. Zero-filled. Only this backend's transfers may use it.
  virtual std::unique_ptr<HostBuffer> allocate_host(std::size_t bytes);
  /// Enqueues a copy of `bytes` of `src` (from `src_offset`) to `dst` on the current queue and
  /// returns; `src` must stay unchanged until the queue has been finished. The default copies at once.
  virtual void upload_async(Buffer& dst, std::size_t dst_offset, const HostBuffer& src, std::size_t src_offset,
                            std::size_t bytes);
  /// Enqueues a copy to host memory on the current queue and returns; `dst` holds the bytes once
  /// finish_queue() of that queue or synchronize() has returned. The default copies at once.
  virtual void download_async(const Buffer& src, std::size_t src_offset, HostBuffer& dst, std::size_t dst_offset,
                              std::size_t bytes);

  // Kernels: DESIGN.md §3, one method per contract.

  /// §3.1: dst(x, y) from `src` through a map of dst.width * dst.height (x, y) int32 pairs in
  /// Q5 fixed point (source coordinate * 32, row-major, packed). Bilinear with 5-bit weights:
  /// (sum w * p + 512) >> 10; taps outside the source read 0.
  virtual void rectify(const Buffer& src, const Plane& src_plane, const Buffer& map, Buffer& dst,
                       const Plane& dst_plane) = 0;

  /// §3.2: fills levels 1.. of `pyramid` (uint8) from level 0, each from the level above, with
  /// `resize_table` (ResizeTables::packed) laid out by `level_offset`.
  virtual void build_pyramid(Buffer& pyramid, const PyramidLayout& layout, const Buffer& resize_table,
                             const std::vector<std::int32_t>& level_offset) = 0;

  /// §3.3: uint16 response of every level into `responses` (laid out by `response_layout`, which
  /// has the pyramid's level sizes), through the 65 536-byte `lut`.
  virtual void fast_crf(const Buffer& pyramid, const PyramidLayout& layout, const Buffer& lut,
                        Buffer& responses, const PyramidLayout& response_layout,
                        const FastParams& params) = 0;

  /// §3.4: per cell of every level, the maximum response (ties to the smaller row, then column)
  /// as a Keypoint in `cells[first_cell + row * cols + col]`; response 0 when the cell has none.
  virtual void cull_cells(const Buffer& responses, const PyramidLayout& response_layout,
                          const CellLayout& cell_layout, Buffer& cells) = 0;

  /// §3.5: clears (sets all fields to 0) every keypoint of the dense cell array that PFA rejects.
  virtual void pfa_filter(Buffer& cells, const CellLayout& cell_layout, const PfaParams& params) = 0;

  /// Canonical compaction: copies the non-empty cells (response > 0), in cell order, into `out`
  /// and writes their number into its count. `out.capacity` >= total cells.
  virtual void compact_keypoints(const Buffer& cells, int total_cells, DeviceList out) = 0;

  /// §3.3-§3.5 and the compaction as the frontend runs them: fast_crf, cull_cells, pfa_filter
  /// (when `pfa` is not null) and compact_keypoints, with the same arguments and the same bytes in
  /// `cells` and `out`. The default makes those four calls; a backend may override it to run them
  /// in fewer launches where it pays (vulkan and opencl on GPUs: FAST with culling, then PFA with
  /// the compaction), and may then leave `responses` unwritten.
  virtual void detect_keypoints(const Buffer& pyramid, const PyramidLayout& layout, const Buffer& lut,
                                Buffer& responses, const PyramidLayout& response_layout, const FastParams& fast,
                                const CellLayout& cell_layout, Buffer& cells, const PfaParams* pfa,
                                DeviceList out);

  /// §3.6: sets angle_bin of each listed keypoint from the intensity centroid on the unblurred
  /// level. `umax` is build_orientation_umax(); `boundaries` build_orientation_boundaries(bins).
  virtual void orient(const Buffer& pyramid, const PyramidLayout& layout, DeviceList keypoints,
                      const std::array<int, 16>& umax, const Buffer& boundaries, int bins) = 0;

  /// §3.7: 7x7 separable blur of every level of `pyramid` into `blurred` (same layout).
  virtual void blur(const Buffer& pyramid, const PyramidLayout& layout, Buffer& blurred,
                    const std::array<std::int32_t, 7>& taps) = 0;

  /// §3.8: one 32-byte Descriptor per listed keypoint into `descriptors`, from the blurred level,
  /// with `pattern` = build_orb_pattern_table(bins).
  virtual void orb_describe(const Buffer& blurred, const PyramidLayout& layout,
                            ConstDeviceList keypoints, const Buffer& pattern, Buffer& descriptors) = 0;

  /// §3.9: one StereoMatch per left keypoint into `matches`. Pyramids are the unblurred images.
  virtual void stereo_match(const Buffer& left_pyramid, const Buffer& right_pyramid,
                            const PyramidLayout& layout, ConstDeviceList left_keypoints,
                            const Buffer& left_descriptors, ConstDeviceList right_keypoints,
                            const Buffer& right_descriptors, const StereoParams& params,
                            Buffer& matches) = 0;

  /// §3.10: one ProjectionResult per query into `results`. `queries` holds `num_queries`
  /// ProjectionQuery records and `query_descriptors` as many Descriptors. Keypoint positions are
  /// compared at level 0 in 1/256 px: (x * S[n] + 128) >> 8. A keypoint is a candidate when
  /// |u_kp - u| <= radius and |v_kp - v| <= radius and its level is in [min_level, max_level].
  virtual void projection_match(ConstDeviceList keypoints, const Buffer& keypoint_descriptors,
                                const Buffer& queries, const Buffer& query_descriptors,
                                int num_queries, const std::vector<std::int32_t>& scales_q16,
                                Buffer& results) = 0;

 protected:
  /// BackendError "<name>: <call>(q): queues are 0 to N-1" unless 0 <= queue < queue_count().
  void check_queue_index(int queue, const char* call) const;
};

}  // namespace porta

/// Declares, inside a backend class, the overrides of every kernel method above (one list for all
/// backends, so that a new kernel is declared once). Each backend defines them in its *_kernels
/// sources.
#define PORTA_BACKEND_KERNEL_OVERRIDES                                                                \
  void rectify(const ::porta::Buffer& src, const ::porta::Plane& src_plane, const ::porta::Buffer& map, \
               ::porta::Buffer& dst, const ::porta::Plane& dst_plane) override;                      \
  void build_pyramid(::porta::Buffer& pyramid, const ::porta::PyramidLayout& layout,                  \
                     const ::porta::Buffer& resize_table, const std::vector<std::int32_t>& level_offset) \
      override;                                                                                       \
  void fast_crf(const ::porta::Buffer& pyramid, const ::porta::PyramidLayout& layout,                 \
                const ::porta::Buffer& lut, ::porta::Buffer& responses,                               \
                const ::porta::PyramidLayout& response_layout, const ::porta::FastParams& params) override; \
  void cull_cells(const ::porta::Buffer& responses, const ::porta::PyramidLayout& response_layout,    \
                  const ::porta::CellLayout& cell_layout, ::porta::Buffer& cells) override;           \
  void pfa_filter(::porta::Buffer& cells, const ::porta::CellLayout& cell_layout,                     \
                  const ::porta::PfaParams& params) override;                                         \
  void compact_keypoints(const ::porta::Buffer& cells, int total_cells, ::porta::DeviceList out) override; \
  void orient(const ::porta::Buffer& pyramid, const ::porta::PyramidLayout& layout,                   \
              ::porta::DeviceList keypoints, const std::array<int, 16>& umax,                         \
              const ::porta::Buffer& boundaries, int bins) override;                                  \
  void blur(const ::porta::Buffer& pyramid, const ::porta::PyramidLayout& layout,                     \
            ::porta::Buffer& blurred, const std::array<std::int32_t, 7>& taps) override;              \
  void orb_describe(const ::porta::Buffer& blurred, const ::porta::PyramidLayout& layout,             \
                    ::porta::ConstDeviceList keypoints, const ::porta::Buffer& pattern,               \
                    ::porta::Buffer& descriptors) override;                                           \
  void stereo_match(const ::porta::Buffer& left_pyramid, const ::porta::Buffer& right_pyramid,        \
                    const ::porta::PyramidLayout& layout, ::porta::ConstDeviceList left_keypoints,    \
                    const ::porta::Buffer& left_descriptors, ::porta::ConstDeviceList right_keypoints, \
                    const ::porta::Buffer& right_descriptors, const ::porta::StereoParams& params,    \
                    ::porta::Buffer& matches) override;                                               \
  void projection_match(::porta::ConstDeviceList keypoints, const ::porta::Buffer& keypoint_descriptors, \
                        const ::porta::Buffer& queries, const ::porta::Buffer& query_descriptors,     \
                        int num_queries, const std::vector<std::int32_t>& scales_q16,                 \
                        ::porta::Buffer& results) override

/// Declares, inside a backend class with several queues, the overrides of the queue and
/// asynchronous-transfer calls (queue_count() aside, which each defines inline).
#define PORTA_BACKEND_QUEUE_OVERRIDES                                                                 \
  void use_queue(int queue) override;                                                                 \
  void queue_wait(int other) override;                                                                \
  void finish_queue(int queue) override;                                                              \
  std::unique_ptr<::porta::HostBuffer> allocate_host(std::size_t bytes) override;                     \
  void upload_async(::porta::Buffer& dst, std::size_t dst_offset, const ::porta::HostBuffer& src,     \
                    std::size_t src_offset, std::size_t bytes) override;                              \
  void download_async(const ::porta::Buffer& src, std::size_t src_offset, ::porta::HostBuffer& dst,   \
                      std::size_t dst_offset, std::size_t bytes) override
