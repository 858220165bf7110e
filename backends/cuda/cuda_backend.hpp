// The CUDA backend: one device, kMaxQueues queues (non-blocking streams; the Frontend gives each
// frame in flight two, one per image of a stereo pair), device memory from cudaMalloc (never
// managed memory), page-locked host buffers for asynchronous transfers (allocate_host), pinned
// upload staging per queue, grow-only scratch buffers per queue. The kernel contracts of DESIGN.md §3 are
// dispatched from *_ops.cpp to the kernels of *_kernels.cu (kernels.hpp is the boundary).
//
// Work submission (DESIGN.md §4, "CUDA graphs to cut launch overhead"): every copy, fill and
// launch becomes an operation appended to the current queue's pending segment, together with the
// bytes of its arguments (device addresses included). A segment is submitted ("flushed") at the
// next synchronisation point of that queue: a download, synchronize(), finish_queue(), use_queue()
// leaving it, queue_wait() naming it, or a grow of its scratch/staging memory. A segment whose argument
// bytes equal those of a segment seen before is replayed from an instantiated CUDA graph
// (cudaGraphLaunch, one call for the whole chain); a new one is launched operation by operation
// and captured into a graph when seen again (at once with PORTA_CUDA_GRAPHS=eager). The Frontend
// issues the same calls on the same buffers every frame, so from the third frame on each camera's
// chain is one graph launch. Freeing any buffer empties the graph cache (a graph names addresses,
// and a new allocation may reuse one). PORTA_CUDA_GRAPHS=0 launches every operation at once, as it
// is called.
// Kernels are asynchronous until synchronize() or a download().
#pragma once

#include <cuda_runtime_api.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <type_traits>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "porta/backend.hpp"
#include "porta/registry.hpp"

namespace porta::cuda {

/// One device as the selection sees it.
struct DeviceEntry {
  int index = 0;
  std::string name;
  int major = 0;
  int minor = 0;
  std::size_t memory_bytes = 0;
  /// "NVIDIA H100 80GB HBM3 (sm_90, 79 GiB)".
  std::string label() const;
};

/// Every CUDA device, in runtime order. Empty when there is none; `why` then says what the runtime
/// answered ("cudaGetDeviceCount: cudaErrorNoDevice (...)" or "0 devices").
std::vector<DeviceEntry> enumerate_devices(std::string* why = nullptr);

/// "[0] NVIDIA H100 80GB HBM3 (sm_90, 79 GiB); [1] ...".
std::string list_devices(const std::vector<DeviceEntry>& devices);

class CudaBackend;

/// What a buffer knows of the backend that made it: freeing device memory must first submit the
/// operations still pending on the backend (they may use it). Cleared when the backend goes.
struct BackendLink {
  CudaBackend* backend = nullptr;
};

/// Page-locked host memory (cudaHostAlloc): the device copies to and from it without the host.
class CudaHostBuffer final : public HostBuffer {
 public:
  CudaHostBuffer(std::uint8_t* pinned, std::size_t bytes, int device, std::shared_ptr<BackendLink> link)
      : HostBuffer(pinned, bytes), device_(device), link_(std::move(link)) {}
  ~CudaHostBuffer() override;
  /// True when this buffer was made by the backend behind `link`.
  bool made_by(const BackendLink* link) const { return link_.get() == link; }

 private:
  int device_;
  std::shared_ptr<BackendLink> link_;
};

class CudaBuffer final : public Buffer {
 public:
  CudaBuffer(std::uint8_t* device_ptr, std::size_t bytes, int device, std::shared_ptr<BackendLink> link)
      : Buffer(bytes), ptr_(device_ptr), device_(device), link_(std::move(link)) {}
  ~CudaBuffer() override;
  std::uint8_t* data() const { return ptr_; }

 private:
  std::uint8_t* ptr_;
  int device_;
  std::shared_ptr<BackendLink> link_;
};

/// The device address of a buffer made by a CudaBackend, as T.
template <typename T>
T* dev(Buffer& b, std::int64_t offset_bytes = 0) {
  return reinterpret_cast<T*>(static_cast<CudaBuffer&>(b).data() + offset_bytes);
}
template <typename T>
const T* dev(const Buffer& b, std::int64_t offset_bytes = 0) {
  return reinterpret_cast<const T*>(static_cast<const CudaBuffer&>(b).data() + offset_bytes);
}

/// How cull_cells splits its work ($PORTA_CUDA_CULL; the paper's Tables I and II). Same bytes.
enum class CullVariant {
  kMlptTewa,   ///< "mlpt_tewa" (default): MLPT threads, several small cells packed per block
  kMlptBlock,  ///< "mlpt_block": MLPT threads, one cell per 128-thread block (no TEWA)
  kLog2Block,  ///< "log2_block": one block per cell, plain shared-memory log2 tree reduction
};
const char* cull_variant_name(CullVariant v);
/// "mlpt_tewa", "mlpt_block" or "log2_block"; BackendError naming the allowed values otherwise.
CullVariant parse_cull_variant(const std::string& text);

/// When segments are replayed as CUDA graphs ($PORTA_CUDA_GRAPHS).
enum class GraphMode {
  kOff,     ///< "0": every operation is launched when called
  kRepeat,  ///< "1" (default): a segment is captured the second time it is seen
  kEager,   ///< "eager": captured the first time (every segment of two operations or more)
};

/// Counters of the submission path since the backend was made (or reset_stats()).
struct CudaStats {
  std::uint64_t operations = 0;        ///< copies, fills and launcher calls enqueued
  std::uint64_t segments = 0;          ///< flushed segments
  std::uint64_t direct_segments = 0;   ///< launched operation by operation
  std::uint64_t graph_captures = 0;    ///< captured, instantiated and launched
  std::uint64_t graph_replays = 0;     ///< launched from the cache
  std::uint64_t capture_failures = 0;  ///< could not be captured (then launched directly)
  std::uint64_t queue_waits = 0;       ///< cudaStreamWaitEvent calls (queue_wait)
  std::uint64_t cache_drops = 0;       ///< graph cache emptied because memory was freed
};

class CudaBackend final : public Backend {
 public:
  static constexpr int kMaxQueues = 16;

  /// Selects the device by options.device, else $PORTA_CUDA_DEVICE, else device 0: an index or a
  /// case-insensitive substring of the device name. Throws BackendError listing the devices found.
  /// Reads $PORTA_CUDA_GRAPHS (0, 1, eager), $PORTA_CUDA_STREAMS (0: one queue, all work on one
  /// stream; 1, the default: kMaxQueues), $PORTA_CUDA_CULL and $PORTA_CUDA_MLPT_NMAX.
  explicit CudaBackend(const BackendOptions& options = {});
  ~CudaBackend() override;

  std::string name() const override { return "cuda"; }
  std::string device_name() const override { return device_.label(); }

  std::unique_ptr<Buffer> allocate(std::size_t bytes) override;
  void upload(Buffer& dst, std::size_t dst_offset, const void* src, std::size_t bytes) override;
  void download(const Buffer& src, std::size_t src_offset, void* dst, std::size_t bytes) override;
  void fill(Buffer& dst, std::size_t offset, std::size_t bytes, std::uint8_t value) override;
  void synchronize() override;

  /// kMaxQueues, or 1 when streams are off ($PORTA_CUDA_STREAMS=0).
  int queue_count() const override { return streams_enabled_ ? kMaxQueues : 1; }
  /// use_queue: queue q's stream from now on (with streams off every queue is stream 0); submits
  /// what the queue being left has pending, so that it runs while the host records the next one.
  /// queue_wait: an event recorded on `other`'s stream that the current stream waits for.
  /// upload_async / download_async: `src` / `dst` must come from this backend's allocate_host()
  /// (BackendError otherwise): the copy is then a plain DMA that a CUDA graph can hold.
  PORTA_BACKEND_QUEUE_OVERRIDES;

  PORTA_BACKEND_KERNEL_OVERRIDES;

  // ---- tuning (environment at construction; settable for comparisons, e.g. the ablation tool) ----
  CullVariant cull_variant() const { return cull_variant_; }
  void set_cull_variant(CullVariant v) { cull_variant_ = v; }
  GraphMode graph_mode() const { return graph_mode_; }
  /// Submits what is pending first; switching to kOff keeps the cached graphs.
  void set_graph_mode(GraphMode mode);
  bool streams_enabled() const { return streams_enabled_; }
  /// Synchronizes first; false sends all later work to queue 0.
  void set_streams_enabled(bool on);
  const CudaStats& stats() const { return stats_; }
  void reset_stats() { stats_ = {}; }
  /// Instantiated graphs in the cache (at most kMaxGraphs).
  std::size_t cached_graphs() const { return graphs_.size(); }

  // ---- for the *_ops.cpp files ----
  /// Makes this backend's device current on the calling thread (every entry point does).
  void activate() const;
  /// Scratch device memory of the current queue that lives as long as the backend, grown on demand
  /// (never shrunk); zero when first allocated or grown. Queues never share scratch memory.
  Buffer& scratch(const std::string& name, std::size_t bytes);
  /// Rows a culling thread scans at most (MLPT's N_max): $PORTA_CUDA_MLPT_NMAX, default 8.
  int mlpt_nmax() const { return mlpt_nmax_; }

  /// Appends `Launcher(args..., stream)` to the current queue's segment; the bytes of `args` (and
  /// the launcher's address) are the segment's key for graph replay, so every argument must be a
  /// value whose bytes are its meaning (pointers, integers, the padding-free structs of kernels.hpp).
  template <auto Launcher, typename... Args>
  void enqueue(const char* name, Args... args) {
    static_assert((std::has_unique_object_representations_v<Args> && ...),
                  "launcher arguments must have no padding bytes: they key the graph cache");
    static_assert(std::is_invocable_r_v<cudaError_t, decltype(Launcher), const Args&..., cudaStream_t>);
    Queue& q = queues_[current_];
    append_key(q.signature, reinterpret_cast<std::uintptr_t>(Launcher));
    (append_key(q.signature, args), ...);
    q.pending.push_back(Op{name, [args...](cudaStream_t s) -> cudaError_t { return Launcher(args..., s); }});
    ++stats_.operations;
    if (graph_mode_ == GraphMode::kOff) flush(current_);
  }

  /// Submits every pending segment and waits for the device (buffer destructors call it). Never
  /// throws: an error is kept and thrown by the next download() or synchronize().
  void quiesce_before_free() noexcept;

  /// Frames in flight multiply the segments (each slot's buffers, each pinned input image): room
  /// for 16 slots x 3 segments x a few input images.
  static constexpr std::size_t kMaxGraphs = 256;
  static constexpr std::size_t kMaxSeen = 4096;  ///< segment hashes remembered for kRepeat

 private:
  struct Op {
    const char* name;
    std::function<cudaError_t(cudaStream_t)> run;
  };
  struct Queue {
    cudaStream_t stream = nullptr;
    cudaEvent_t done = nullptr;        // recorded by queue_wait naming this queue
    cudaEvent_t arena_free = nullptr;  // after the last segment that read the upload arena
    std::vector<Op> pending;
    std::vector<std::uint8_t> signature;
    // Pinned upload arena: each segment takes its uploads' staging from offset 0 on, so that the
    // same calls get the same addresses (and the same graph) every frame.
    std::uint8_t* arena = nullptr;
    std::size_t arena_bytes = 0;
    std::size_t arena_used = 0;
    bool arena_busy = false;
    bool may_run = false;  // work was submitted since the last host wait: synchronize() waits for it
    // Pinned download staging (downloads wait, so it is free again when download() returns).
    std::uint8_t* readback = nullptr;
    std::size_t readback_bytes = 0;
    std::map<std::string, std::unique_ptr<Buffer>> scratch;
  };
  struct CachedGraph {
    std::uint64_t hash = 0;
    std::vector<std::uint8_t> signature;
    cudaGraphExec_t exec = nullptr;
    std::uint64_t last_use = 0;
  };

  template <typename T>
  static void append_key(std::vector<std::uint8_t>& sig, const T& value) {
    const std::size_t at = sig.size();
    sig.resize(at + (sizeof(T) + 7) / 8 * 8, 0);
    std::memcpy(sig.data() + at, &value, sizeof(T));
  }

  void create_resources();
  void release_resources() noexcept;
  void throw_deferred_error();
  /// Destroys every cached graph (memory they may name is being freed).
  void drop_graphs() noexcept;
  /// Submits queue q's pending segment (graph replay, capture, or direct launches).
  void flush(int q);
  void flush_all();
  void run_direct(Queue& q, const std::vector<Op>& ops);
  bool capture_and_launch(Queue& q, const std::vector<Op>& ops, std::vector<std::uint8_t>&& sig,
                          std::uint64_t hash);
  /// `bytes` of the current queue's upload arena for the segment being recorded.
  std::uint8_t* arena_take(std::size_t bytes);
  std::uint8_t* readback(Queue& q, std::size_t bytes);
  void sync_queue(Queue& q, const char* where);

  DeviceEntry device_;
  int mlpt_nmax_ = 8;
  CullVariant cull_variant_ = CullVariant::kMlptTewa;
  GraphMode graph_mode_ = GraphMode::kRepeat;
  bool streams_enabled_ = true;
  std::array<Queue, kMaxQueues> queues_{};
  int current_ = 0;
  std::vector<CachedGraph> graphs_;
  std::uint64_t graph_clock_ = 0;
  std::unordered_set<std::uint64_t> seen_;           // segments launched once (kRepeat)
  std::unordered_set<std::uint64_t> uncapturable_;   // never tried again
  std::shared_ptr<BackendLink> link_;
  std::string deferred_error_;
  CudaStats stats_;
};

/// Free functions for operations that are runtime calls rather than kernels (enqueue<...>).
cudaError_t op_copy_h2d(std::uint8_t* dst, const std::uint8_t* src, std::size_t bytes, cudaStream_t stream);
cudaError_t op_copy_d2h(std::uint8_t* dst, const std::uint8_t* src, std::size_t bytes, cudaStream_t stream);
cudaError_t op_copy_d2d(std::uint8_t* dst, const std::uint8_t* src, std::size_t bytes, cudaStream_t stream);
cudaError_t op_fill(std::uint8_t* dst, int value, std::size_t bytes, cudaStream_t stream);

}  // namespace porta::cuda
