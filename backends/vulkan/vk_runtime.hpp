// The Vulkan runtime of one backend: device memory, the pending batch of commands and its
// submission (with replay of identical batches), pipelines created from the embedded SPIR-V, and
// the descriptor-set cache. See vulkan_backend.hpp for the design and for how to add a kernel.
// Internal to backends/vulkan.
#pragma once

#include <vulkan/vulkan.h>

#include <array>
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
/// freed once no pending command uses it.
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

class Runtime : public std::enable_shared_from_this<Runtime> {
 public:
  explicit Runtime(const BackendOptions& options);
  ~Runtime();
  Runtime(const Runtime&) = delete;
  Runtime& operator=(const Runtime&) = delete;

  Context& context() { return *ctx_; }
  const VulkanStats& stats() const { return stats_; }

  // ---- memory (Backend semantics: asynchronous until flush) ----
  std::unique_ptr<Buffer> allocate(std::size_t bytes);
  void upload(Buffer& dst, std::size_t offset, const void* src, std::size_t bytes);
  void download(const Buffer& src, std::size_t offset, void* dst, std::size_t bytes);
  void fill(Buffer& dst, std::size_t offset, std::size_t bytes, std::uint8_t value);
  /// Submits the pending batch (if any) and waits for it.
  void flush();
  /// Backend::kernel_times: flushes, then the totals of the timed dispatches.
  std::vector<KernelTime> kernel_times(bool reset);

  /// Records a dispatch of `kernel` (a shader of shaders/vulkan) binding `buffers` to set 0,
  /// bindings 0..N-1, with `params` as push constants or in the parameter buffer (whichever the
  /// shader declares). Nothing is recorded when `work` is empty.
  template <typename Params>
  void dispatch(const char* kernel, std::initializer_list<const Buffer*> buffers, const Params& params,
                Work work) {
    static_assert(std::is_trivially_copyable_v<Params>);
    dispatch_raw(kernel, buffers, &params, sizeof(Params), work);
  }
  void dispatch_raw(const char* kernel, std::initializer_list<const Buffer*> buffers, const void* params,
                    std::uint32_t params_bytes, Work work);

  /// Called by ~VulkanBuffer.
  void retire(DeviceMemory memory) noexcept;

 private:
  /// One kernel: its pipeline and what its SPIR-V declares (vk_pipelines.cpp).
  struct Kernel {
    std::string name;
    std::uint32_t index = 0;         ///< creation order, for batch signatures
    std::uint32_t bindings = 0;      ///< storage buffers of set 0
    bool push = false;               ///< parameters as push constants
    bool params_buffer = false;      ///< parameters in set 1, binding 0
    std::uint32_t params_bytes = 0;  ///< fixed by the first dispatch
    std::uint32_t local[3] = {1, 1, 1};
    Unique<VkShaderModule> module;
    Unique<VkPipelineLayout> layout;
    Unique<VkPipeline> pipeline;
  };
  /// One recorded-to-be command of the pending batch.
  struct Command {
    enum class Kind : std::uint8_t { kDispatch, kCopy, kFill };
    Kind kind = Kind::kDispatch;
    std::vector<std::uint64_t> ids;  ///< buffers used: bindings in order; copy: src, dst; fill: dst
    // kDispatch
    const Kernel* kernel = nullptr;
    VkDescriptorSet set = VK_NULL_HANDLE;
    std::uint32_t params_offset = 0;  ///< dynamic offset into the parameter buffer
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

  DeviceMemory make_memory(VkDeviceSize bytes, bool host);
  const VulkanBuffer& vk(const Buffer& b, const char* call) const;
  bool pending_uses(std::uint64_t id) const;
  void note_use(std::uint64_t id);
  void destroy_now(DeviceMemory memory);
  void collect_garbage();
  /// A slice of the staging buffer for `bytes` bytes in this batch (flushes or grows as needed).
  VkDeviceSize reserve_staging(VkDeviceSize bytes);
  void record_copy(const DeviceMemory& src, VkDeviceSize src_offset, const DeviceMemory& dst,
                   VkDeviceSize dst_offset, VkDeviceSize bytes);
  Kernel& kernel(const char* name, std::uint32_t params_bytes);
  VkDescriptorSetLayout set_layout(std::uint32_t bindings);
  VkDescriptorSet descriptor_set(const Kernel& k, const std::vector<const VulkanBuffer*>& buffers);
  VkDescriptorSet allocate_set(VkDescriptorSetLayout layout, VkDescriptorPool& from);
  void record(VkCommandBuffer cmd, bool one_time);
  std::vector<std::uint64_t> signature() const;
  /// BackendOptions::profile_kernels: the timestamp query pool, or a BackendError when the queue
  /// cannot write timestamps.
  void create_timestamp_pool();
  /// After a batch's fence: adds its dispatches' timestamps to profile_.
  void read_timestamps();

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

  // Parameter buffer: a per-batch bump allocator over host-visible memory.
  DeviceMemory params_;
  Unique<VkDescriptorPool> params_pool_;
  VkDescriptorSet params_set_ = VK_NULL_HANDLE;
  VkDeviceSize params_used_ = 0;

  // Staging: a per-batch bump allocator, grown on demand.
  DeviceMemory staging_;
  VkDeviceSize staging_used_ = 0;

  // The pending batch and the recorded ones.
  std::vector<Command> pending_;
  std::vector<std::uint64_t> pending_ids_;
  bool pending_dispatch_ = false;
  std::vector<DeviceMemory> garbage_;  // retired while a pending command used them
  Unique<VkCommandPool> command_pool_;
  Unique<VkFence> fence_;
  VkCommandBuffer transfer_cmd_ = VK_NULL_HANDLE;  // for batches of copies and fills only
  std::vector<CachedBatch> cache_;
  std::uint64_t batch_clock_ = 0;

  // Per-kernel timing (BackendOptions::profile_kernels): two timestamps around each of the first
  // kMaxTimedDispatches dispatches of a batch; later ones in the same batch are not timed.
  static constexpr std::uint32_t kMaxTimedDispatches = 1024;
  Unique<VkQueryPool> timestamps_;
  std::uint64_t timestamp_mask_ = ~0ull;
  double timestamp_ns_ = 1.0;  ///< ns per timestamp tick
  KernelProfile profile_;
};

}  // namespace porta::vulkan
