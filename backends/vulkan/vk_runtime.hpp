// The Vulkan runtime of one backend: device memory, the pending batch of commands and its
// submission (with replay of identical batches), pipelines created from the embedded SPIR-V, and
// the descriptor-set cache. See vulkan_backend.hpp for the design and for how to add a kernel.
// Internal to backends/vulkan.
#pragma once

#include <vulkan/vulkan.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <initializer_list>
#include <map>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "porta/backend.hpp"
#include "porta/kernel_profile.hpp"
#include "vulkan/vk_context.hpp"
#include "vulkan/vulkan_backend.hpp"

namespace porta::vulkan {

/// Largest parameter block passed in the parameter buffer (set 1, binding 0) of a dispatch.
inline constexpr std::uint32_t kMaxParamsBytes = 1024;
/// Largest push-constant block (the minimum every Vulkan device guarantees).
inline constexpr std::uint32_t kMaxPushBytes = 128;

/// How many invocations a dispatch needs; the runtime turns it into workgroup counts with the
/// shader's local size (and spreads large counts over y, which porta_linear_index() undoes).
struct Work {
  enum class Kind { kItems, kGrid, kGroups };
  Kind kind = Kind::kItems;
  std::uint64_t x = 0;
  std::uint64_t y = 1;
  /// n invocations; the shader's local size must be (X, 1, 1).
  static Work items(std::uint64_t n) { return {Kind::kItems, n, 1}; }
  /// w x h invocations over gl_GlobalInvocationID.xy (rounded up to the local size).
  static Work grid(std::uint64_t w, std::uint64_t h) { return {Kind::kGrid, w, h}; }
  /// n workgroups, one per item.
  static Work groups(std::uint64_t n) { return {Kind::kGroups, n, 1}; }
};

/// A VkBuffer with its own memory, mapped when the memory is host-visible.
struct DeviceMemory {
  Unique<VkDeviceMemory> memory;
  Unique<VkBuffer> buffer;
  void* mapped = nullptr;
  VkDeviceSize size = 0;  ///< of the VkBuffer (a multiple of 4, at least 4)
  std::uint64_t id = 0;   ///< unique for the runtime's life: caches key on it, never on handles
};

/// A Buffer of the Vulkan backend. Its memory is handed back to the runtime on destruction and
/// freed once no pending or running command uses it.
class VulkanBuffer final : public Buffer {
 public:
  VulkanBuffer(std::shared_ptr<Runtime> runtime, DeviceMemory memory, std::size_t bytes);
  ~VulkanBuffer() override;
  const DeviceMemory& memory() const { return memory_; }
  const Runtime* owner() const { return runtime_.get(); }

 private:
  std::shared_ptr<Runtime> runtime_;
  DeviceMemory memory_;
};

/// A HostBuffer of the Vulkan backend (Backend::allocate_host): host-visible, coherent memory,
/// mapped for its whole life, that the device copies to and from in the queue's own batch.
class VulkanHostBuffer final : public HostBuffer {
 public:
  VulkanHostBuffer(std::shared_ptr<Runtime> runtime, DeviceMemory memory, std::size_t bytes);
  ~VulkanHostBuffer() override;
  const DeviceMemory& memory() const { return memory_; }
  const Runtime* owner() const { return runtime_.get(); }

 private:
  std::shared_ptr<Runtime> runtime_;
  DeviceMemory memory_;
};

class Runtime : public std::enable_shared_from_this<Runtime> {
 public:
  using Clock = std::chrono::steady_clock;
  /// The HAL queues (Backend::queue_count()): streams of batches, spread over the device's queues.
  static constexpr int kStreams = 8;

  explicit Runtime(const BackendOptions& options);
  ~Runtime();
  Runtime(const Runtime&) = delete;
  Runtime& operator=(const Runtime&) = delete;

  Context& context() { return *ctx_; }
  /// How long wait_for() polls a fence before it blocks (0: blocks at once).
  void set_fence_poll(std::chrono::microseconds poll) { fence_poll_ = poll; }
  const VulkanStats& stats() const { return stats_; }

  // ---- memory (Backend semantics: asynchronous until a wait) ----
  std::unique_ptr<Buffer> allocate(std::size_t bytes);
  void upload(Buffer& dst, std::size_t offset, const void* src, std::size_t bytes);
  /// Waits for every stream, then copies.
  void download(const Buffer& src, std::size_t offset, void* dst, std::size_t bytes);
  void fill(Buffer& dst, std::size_t offset, std::size_t bytes, std::uint8_t value);
  std::unique_ptr<HostBuffer> allocate_host(std::size_t bytes);
  void upload_async(Buffer& dst, std::size_t dst_offset, const HostBuffer& src, std::size_t src_offset,
                    std::size_t bytes);
  void download_async(const Buffer& src, std::size_t src_offset, HostBuffer& dst, std::size_t dst_offset,
                      std::size_t bytes);

  // ---- streams (vk_streams.cpp; the HAL's queues) ----
  int current_stream() const { return current_; }
  void use_stream(int stream) { current_ = stream; }
  /// Later work on the current stream waits for what `other` has been given so far: its pending
  /// batch is submitted with a semaphore the current stream's next submit waits on.
  void stream_wait(int other);
  /// Submits the stream's pending batch (if any) and waits for it.
  void finish_stream(int stream);
  /// Submits every stream's pending batch without waiting (Backend::flush). With `hold`, a batch
  /// for a queue on which the device still has hold_depth() batches to run is held back instead,
  /// and later ones merged into it, until a later start() finds fewer or the host waits for a batch
  /// after which the device would have nothing to run.
  void start(bool hold = true);
  /// $PORTA_VULKAN_HOLD_BATCHES: how many unfinished batches on a device queue make start() hold
  /// the next one back (0: never; kDefaultHoldDepth by default).
  void set_hold_depth(int depth) { hold_depth_ = depth; }
  /// $PORTA_VULKAN_ALL_BARRIERS=on: a barrier between every two commands of a batch, as before
  /// barriers followed the buffers (push_command).
  void set_all_barriers(bool all) { all_barriers_ = all; }
  int hold_depth() const { return hold_depth_; }
  static constexpr int kDefaultHoldDepth = 1;
  static constexpr int kMaxHoldDepth = 4;
  /// Submits every pending batch and waits for all of them.
  void flush();
  /// Backend::kernel_times: flushes, then the totals of the timed dispatches.
  std::vector<KernelTime> kernel_times(bool reset);

  /// Records a dispatch of `kernel` (a shader of shaders/vulkan) binding `buffers` to set 0,
  /// bindings 0..N-1, with `params` as push constants or in the parameter buffer (whichever the
  /// shader declares), on the current stream. Nothing is recorded when `work` is empty.
  template <typename Params>
  void dispatch(const char* kernel, std::initializer_list<const Buffer*> buffers, const Params& params,
                Work work) {
    static_assert(std::is_trivially_copyable_v<Params>);
    dispatch_raw(kernel, buffers, &params, sizeof(Params), work);
  }
  void dispatch_raw(const char* kernel, std::initializer_list<const Buffer*> buffers, const void* params,
                    std::uint32_t params_bytes, Work work);

  /// Called by ~VulkanBuffer and ~VulkanHostBuffer.
  void retire(DeviceMemory memory) noexcept;

 private:
  /// One kernel: its pipeline and what its SPIR-V declares (vk_pipelines.cpp).
  struct Kernel {
    std::string name;
    std::uint32_t index = 0;         ///< creation order, for batch signatures
    std::uint32_t bindings = 0;      ///< storage buffers of set 0
    std::uint32_t written = 0;       ///< the bindings it may write (not NonWritable), one bit each
    bool push = false;               ///< parameters as push constants
    bool params_buffer = false;      ///< parameters in set 1, binding 0
    std::uint32_t params_bytes = 0;  ///< fixed by the first dispatch
    std::uint32_t local[3] = {1, 1, 1};
    Unique<VkShaderModule> module;
    Unique<VkPipelineLayout> layout;
    Unique<VkPipeline> pipeline;
  };
  /// One recorded-to-be command of a pending batch.
  struct Command {
    enum class Kind : std::uint8_t { kDispatch, kCopy, kFill };
    Kind kind = Kind::kDispatch;
    /// A barrier before it: it may read what any earlier command wrote. False for a command that
    /// touches no buffer the commands since the last barrier write and writes none they use
    /// (push_command), and for one merged beside another stream's (stream_wait): the first
    /// command of its group has it.
    bool barrier_before = true;
    /// The stream whose parameter buffer holds its parameters (kDispatch).
    std::uint8_t params_stream = 0;
    std::vector<std::uint64_t> ids;  ///< buffers used: bindings in order; copy: src, dst; fill: dst
    std::vector<std::uint64_t> writes;  ///< of those, the ones it may write
    // kDispatch
    const Kernel* kernel = nullptr;
    VkDescriptorSet set = VK_NULL_HANDLE;
    std::uint32_t params_offset = 0;  ///< dynamic offset into the stream's parameter buffer
    std::uint32_t push_bytes = 0;
    std::array<std::uint32_t, kMaxPushBytes / 4> push{};
    std::uint32_t groups[3] = {1, 1, 1};
    // kCopy, kFill
    VkBuffer src = VK_NULL_HANDLE;
    VkBuffer dst = VK_NULL_HANDLE;
    VkDeviceSize src_offset = 0;
    VkDeviceSize dst_offset = 0;
    VkDeviceSize bytes = 0;
    std::uint32_t fill_word = 0;
  };
  /// A recorded command buffer and the batch it was recorded from.
  struct CachedBatch {
    std::vector<std::uint64_t> signature;
    std::vector<std::uint64_t> ids;  ///< buffers it references (dropped when one is freed)
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    std::uint64_t last_use = 0;
  };
  /// One HAL queue. Commands are recorded into `pending`; a submit moves them to the device as one
  /// batch, of which a stream has at most one running: recording into a stream whose batch runs
  /// waits for it first, so the batch's staging, parameters and command buffer are free again.
  /// stream_wait() may instead merge another stream's pending commands into this batch, beside
  /// its own (merge_pending): that stream's `carrier` then names this one until the batch has run.
  struct Stream {
    VkQueue queue = VK_NULL_HANDLE;
    int carrier = -1;  ///< the stream whose pending or running batch holds this one's last work
    std::vector<Command> pending;
    std::vector<std::uint64_t> pending_ids;
    std::vector<std::uint64_t> pending_writes;  ///< the ids of pending_ids that a command writes
    bool pending_dispatch = false;
    std::vector<VkSemaphore> waits;  ///< the next submit waits for these (stream_wait)
    // Parameter buffer: a per-batch bump allocator over host-visible memory.
    DeviceMemory params;
    VkDescriptorSet params_set = VK_NULL_HANDLE;
    VkDeviceSize params_used = 0;
    // Staging: a per-batch bump allocator, grown on demand.
    DeviceMemory staging;
    VkDeviceSize staging_used = 0;
    Unique<VkFence> fence;
    VkCommandBuffer transfer_cmd = VK_NULL_HANDLE;  // for batches of copies and fills only
    std::vector<CachedBatch> cache;
    Unique<VkQueryPool> timestamps;  ///< BackendOptions::profile_kernels
    // The running batch, until its fence has been waited for.
    bool running = false;
    std::uint64_t submitted = 0;  ///< the running batch's place in submission order
    std::vector<std::uint64_t> running_ids;
    std::vector<std::uint64_t> running_writes;
    std::vector<const Kernel*> running_timed;   ///< its timed dispatches, in order
    std::vector<VkSemaphore> running_waits;     ///< free again once it has run
  };

  /// Where a buffer's memory is: kernel buffers on the device, staging and host buffers in the
  /// host's memory, parameter blocks as Context::params_memory() says.
  enum class Place { kDevice, kHost, kParams };
  DeviceMemory make_memory(VkDeviceSize bytes, Place place);
  const VulkanBuffer& vk(const Buffer& b, const char* call) const;
  const VulkanHostBuffer& vk_host(const HostBuffer& b, const char* call) const;
  /// True while a pending or running batch of any stream uses the memory.
  bool in_use(std::uint64_t id) const;
  /// True while a command of a pending or running batch of any stream writes the memory.
  bool written(std::uint64_t id) const;
  void destroy_now(DeviceMemory memory);
  void collect_garbage();

  // Streams (vk_streams.cpp).
  void create_streams(bool profile_kernels);
  Stream& current() { return streams_[static_cast<std::size_t>(current_)]; }
  /// Before anything is recorded into `s`: waits for its running batch when nothing is pending.
  void begin_record(Stream& s);
  void note_use(Stream& s, std::uint64_t id);
  void note_write(Stream& s, std::uint64_t id);
  void push_command(Stream& s, Command c);
  /// Submits the pending batch (and waits) with `signal` signalled when it has run.
  void submit(Stream& s, VkSemaphore signal);
  /// Waits for the running batch, reads its timestamps and frees what it held.
  void complete(Stream& s);
  /// How many batches submitted to `queue` have not finished (their fences, not waited for).
  int queue_backlog(VkQueue queue);
  /// True while a batch submitted to s's queue after s's running one has not finished.
  bool queued_behind(const Stream& s);
  /// Submits the batch start() held back, if any.
  void submit_held();
  /// Waits on the host until `fence` has signalled, polling it for fence_poll_ first.
  void wait_for(VkFence fence);
  /// Drops the pending batch (after a failed submit; its commands never ran).
  void drop_pending(Stream& s);
  /// Moves the pending commands of `from` into the pending batch of `into` beside its own: group k
  /// of one (the commands between two barriers) with group k of the other, so that their k-th
  /// steps run at the same time and each stream's order is kept. Both must be on one device queue.
  void merge_pending(int into, int from);
  /// The streams whose work `carrier`'s batch held are free to record again (it has run or was
  /// dropped).
  void release_carried(int carrier);
  VkSemaphore take_semaphore();
  /// upload_async on the transfer queue (Context::transfer_queue()): the copy is submitted there at
  /// once, and the stream's next batch waits for it. False (nothing done) when it must stay in the
  /// stream's order instead: no transfer queue, or a pending or running batch uses either buffer.
  bool upload_on_transfer_queue(Stream& s, const DeviceMemory& from, VkDeviceSize src_offset,
                                const DeviceMemory& to, VkDeviceSize dst_offset, VkDeviceSize bytes);
  /// The transfer queue's command buffers that a finished batch's waits covered are free again.
  void recycle_transfers(const std::vector<VkSemaphore>& waited);
  VkCommandBuffer command_buffer_for(Stream& s);
  void record(const Stream& s, VkCommandBuffer cmd, bool one_time);
  std::vector<std::uint64_t> signature(const Stream& s) const;
  /// BackendOptions::profile_kernels: the stream's timestamp query pool, or a BackendError when the
  /// queue cannot write timestamps.
  Unique<VkQueryPool> create_timestamp_pool();
  /// After a batch's fence: adds its dispatches' timestamps to profile_.
  void read_timestamps(Stream& s);

  /// A slice of the stream's staging buffer for `bytes` bytes in this batch (finishes the stream
  /// or grows the buffer as needed).
  VkDeviceSize reserve_staging(Stream& s, VkDeviceSize bytes);
  void record_copy(Stream& s, const DeviceMemory& src, VkDeviceSize src_offset, const DeviceMemory& dst,
                   VkDeviceSize dst_offset, VkDeviceSize bytes);
  Kernel& kernel(const char* name, std::uint32_t params_bytes);
  /// The dispatch command of a kernel call, checked against the shader (vk_pipelines.cpp); its
  /// parameters are the caller's to place. False when `work` is empty.
  bool make_dispatch(const char* name, std::initializer_list<const Buffer*> buffers, std::uint32_t params_bytes,
                     Work work, Command& c);
  VkDescriptorSetLayout set_layout(std::uint32_t bindings);
  VkDescriptorSet descriptor_set(const Kernel& k, const std::vector<const VulkanBuffer*>& buffers);
  VkDescriptorSet allocate_set(VkDescriptorSetLayout layout, VkDescriptorPool& from);

  std::unique_ptr<Context> ctx_;  // first: destroyed last, after every object below
  VulkanStats stats_;
  std::uint64_t next_id_ = 1;

  // Pipelines and descriptors.
  std::map<std::string, std::unique_ptr<Kernel>> kernels_;
  std::map<std::uint32_t, Unique<VkDescriptorSetLayout>> set_layouts_;
  Unique<VkDescriptorSetLayout> params_layout_;
  std::vector<Unique<VkDescriptorPool>> pools_;
  struct SetEntry {
    VkDescriptorSet set;
    VkDescriptorPool pool;
  };
  std::map<std::vector<std::uint64_t>, SetEntry> sets_;  // key: binding count, then buffer ids
  Unique<VkDescriptorPool> params_pool_;

  // Streams, and what they share.
  Unique<VkCommandPool> command_pool_;
  // The transfer queue's copies: a pool of its family (when it is not the compute family), the
  // command buffer of each copy submitted by the semaphore it signals, and free command buffers.
  Unique<VkCommandPool> transfer_pool_;
  std::vector<std::pair<VkSemaphore, VkCommandBuffer>> transfers_;
  std::vector<VkCommandBuffer> free_transfer_cmds_;
  std::vector<Stream> streams_;
  int current_ = 0;
  std::vector<Unique<VkSemaphore>> semaphores_;  // every semaphore made
  std::vector<VkSemaphore> free_semaphores_;
  std::vector<DeviceMemory> garbage_;  // retired while a pending or running batch used them
  std::uint64_t batch_clock_ = 0;

  // Per-kernel timing (BackendOptions::profile_kernels): two timestamps around each of the first
  // kMaxTimedDispatches dispatches of a batch; later ones in the same batch are not timed.
  static constexpr std::uint32_t kMaxTimedDispatches = 1024;
  std::uint64_t timestamp_mask_ = ~0ull;
  double timestamp_ns_ = 1.0;  ///< ns per timestamp tick
  KernelProfile profile_;
  std::chrono::microseconds fence_poll_{0};
  int hold_depth_ = kDefaultHoldDepth;
  bool all_barriers_ = false;
  std::uint64_t submit_clock_ = 0;
  int held_ = -1;  ///< the stream whose pending batch start() holds back, -1 when none
};

}  // namespace porta::vulkan
