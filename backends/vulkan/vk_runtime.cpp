// Memory, the pending batch and its submission for the Vulkan backend (vulkan_backend.hpp has
// the design). Pipelines and descriptor sets are in vk_pipelines.cpp.
#include "vulkan/vk_runtime.hpp"

#include <algorithm>
#include <cstring>
#include <string>

#include "vulkan/vk_errors.hpp"

namespace porta::vulkan {

namespace {

constexpr std::size_t kMaxCachedBatches = 16;
/// Parameter bytes one batch may use before it is submitted to make room.
constexpr VkDeviceSize kParamsArea = 64 * 1024;
constexpr VkDeviceSize kMinStaging = 1 << 20;

VkDeviceSize align_up(VkDeviceSize v, VkDeviceSize a) { return (v + a - 1) / a * a; }

bool contains(const std::vector<std::uint64_t>& v, std::uint64_t id, std::size_t from = 0) {
  return std::find(v.begin() + static_cast<std::ptrdiff_t>(std::min(from, v.size())), v.end(), id) != v.end();
}

void check_range(const Buffer& b, std::size_t offset, std::size_t bytes, const char* call) {
  if (offset > b.size_bytes() || bytes > b.size_bytes() - offset)
    throw BackendError(std::string("vulkan: ") + call + ": range [" + std::to_string(offset) + ", +" +
                       std::to_string(bytes) + ") is outside the buffer of " +
                       std::to_string(b.size_bytes()) + " bytes");
}

/// Parameters of shaders/vulkan/fill_bytes.comp.
struct FillBytesParams {
  std::uint32_t offset, count, value;
};

}  // namespace

VulkanBuffer::VulkanBuffer(std::shared_ptr<Runtime> runtime, DeviceMemory memory, std::size_t bytes)
    : Buffer(bytes), runtime_(std::move(runtime)), memory_(std::move(memory)) {}

VulkanBuffer::~VulkanBuffer() { runtime_->retire(std::move(memory_)); }

Runtime::Runtime(const BackendOptions& options) : ctx_(std::make_unique<Context>(options)) {
  const VkDevice dev = ctx_->device();

  auto pool_info = make_info<VkCommandPoolCreateInfo>(VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO);
  pool_info.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pool_info.queueFamilyIndex = ctx_->queue_family();
  VkCommandPool pool = VK_NULL_HANDLE;
  check(vkCreateCommandPool(dev, &pool_info, nullptr, &pool), "vkCreateCommandPool");
  command_pool_ = Unique<VkCommandPool>(dev, pool, vkDestroyCommandPool);

  auto fence_info = make_info<VkFenceCreateInfo>(VK_STRUCTURE_TYPE_FENCE_CREATE_INFO);
  VkFence fence = VK_NULL_HANDLE;
  check(vkCreateFence(dev, &fence_info, nullptr, &fence), "vkCreateFence");
  fence_ = Unique<VkFence>(dev, fence, vkDestroyFence);

  auto cmd_info = make_info<VkCommandBufferAllocateInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO);
  cmd_info.commandPool = pool;
  cmd_info.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  cmd_info.commandBufferCount = 1;
  check(vkAllocateCommandBuffers(dev, &cmd_info, &transfer_cmd_), "vkAllocateCommandBuffers", "transfers");
  if (options.profile_kernels) create_timestamp_pool();

  // The parameter buffer: one dynamic storage-buffer descriptor, each dispatch at its own offset.
  params_ = make_memory(kParamsArea + kMaxParamsBytes, true);
  VkDescriptorSetLayoutBinding binding{};
  binding.binding = 0;
  binding.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER_DYNAMIC;
  binding.descriptorCount = 1;
  binding.stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
  auto layout_info =
      make_info<VkDescriptorSetLayoutCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO);
  layout_info.bindingCount = 1;
  layout_info.pBindings = &binding;
  VkDescriptorSetLayout layout = VK_NULL_HANDLE;
  check(vkCreateDescriptorSetLayout(dev, &layout_info, nullptr, &layout), "vkCreateDescriptorSetLayout",
        "parameters");
  params_layout_ = Unique<VkDescriptorSetLayout>(dev, layout, vkDestroyDescriptorSetLayout);

  VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER_DYNAMIC, 1};
  auto params_pool_info =
      make_info<VkDescriptorPoolCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
  params_pool_info.maxSets = 1;
  params_pool_info.poolSizeCount = 1;
  params_pool_info.pPoolSizes = &size;
  VkDescriptorPool params_pool = VK_NULL_HANDLE;
  check(vkCreateDescriptorPool(dev, &params_pool_info, nullptr, &params_pool), "vkCreateDescriptorPool",
        "parameters");
  params_pool_ = Unique<VkDescriptorPool>(dev, params_pool, vkDestroyDescriptorPool);
  auto set_info = make_info<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
  set_info.descriptorPool = params_pool;
  set_info.descriptorSetCount = 1;
  set_info.pSetLayouts = &layout;
  check(vkAllocateDescriptorSets(dev, &set_info, &params_set_), "vkAllocateDescriptorSets", "parameters");
  VkDescriptorBufferInfo buffer_info{params_.buffer.get(), 0, kMaxParamsBytes};
  auto write = make_info<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
  write.dstSet = params_set_;
  write.dstBinding = 0;
  write.descriptorCount = 1;
  write.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER_DYNAMIC;
  write.pBufferInfo = &buffer_info;
  vkUpdateDescriptorSets(dev, 1, &write, 0, nullptr);
}

Runtime::~Runtime() {
  // Every submitted batch has been waited for; a pending one is dropped (it never ran).
  if (ctx_) vkQueueWaitIdle(ctx_->queue());
}

// ---- Memory --------------------------------------------------------------------------------------

DeviceMemory Runtime::make_memory(VkDeviceSize bytes, bool host) {
  const VkDevice dev = ctx_->device();
  DeviceMemory m;
  m.size = std::max<VkDeviceSize>(4, align_up(bytes, 4));  // vkCmdFillBuffer works on whole words
  m.id = next_id_++;
  auto info = make_info<VkBufferCreateInfo>(VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO);
  info.size = m.size;
  info.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT |
               VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  const std::string what = std::to_string(bytes) + " bytes";
  VkBuffer buffer = VK_NULL_HANDLE;
  check(vkCreateBuffer(dev, &info, nullptr, &buffer), "vkCreateBuffer", what);
  m.buffer = Unique<VkBuffer>(dev, buffer, vkDestroyBuffer);

  VkMemoryRequirements req{};
  vkGetBufferMemoryRequirements(dev, buffer, &req);
  const MemoryChoice choice =
      host ? ctx_->host_memory(req.memoryTypeBits) : ctx_->device_memory(req.memoryTypeBits);
  auto alloc = make_info<VkMemoryAllocateInfo>(VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO);
  alloc.allocationSize = req.size;
  alloc.memoryTypeIndex = choice.type_index;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  check(vkAllocateMemory(dev, &alloc, nullptr, &memory), "vkAllocateMemory", what);
  m.memory = Unique<VkDeviceMemory>(dev, memory, vkFreeMemory);
  check(vkBindBufferMemory(dev, buffer, memory, 0), "vkBindBufferMemory", what);
  if (choice.mapped) check(vkMapMemory(dev, memory, 0, VK_WHOLE_SIZE, 0, &m.mapped), "vkMapMemory", what);
  return m;
}

std::unique_ptr<Buffer> Runtime::allocate(std::size_t bytes) {
  DeviceMemory m = make_memory(bytes, false);
  ++stats_.buffers_allocated;
  if (m.mapped != nullptr) {
    std::memset(m.mapped, 0, m.size);
  } else {
    Command c;
    c.kind = Command::Kind::kFill;
    c.dst = m.buffer.get();
    c.bytes = m.size;
    c.ids = {m.id};
    note_use(m.id);
    pending_.push_back(std::move(c));
  }
  return std::make_unique<VulkanBuffer>(shared_from_this(), std::move(m), bytes);
}

const VulkanBuffer& Runtime::vk(const Buffer& b, const char* call) const {
  const auto* v = dynamic_cast<const VulkanBuffer*>(&b);
  if (v == nullptr || v->owner() != this)
    throw BackendError(std::string("vulkan: ") + call + ": the buffer was not made by this Vulkan backend");
  return *v;
}

bool Runtime::pending_uses(std::uint64_t id) const { return contains(pending_ids_, id); }

void Runtime::note_use(std::uint64_t id) {
  if (!pending_uses(id)) pending_ids_.push_back(id);
}

VkDeviceSize Runtime::reserve_staging(VkDeviceSize bytes) {
  const VkDeviceSize need = align_up(std::max<VkDeviceSize>(bytes, 1), 16);
  if (staging_used_ + need > staging_.size) {
    if (staging_used_ > 0) flush();  // the batch's copies read or write the staging buffer
    if (need > staging_.size) {
      const VkDeviceSize grown = std::max({kMinStaging, need, 2 * staging_.size});
      if (staging_.buffer) destroy_now(std::move(staging_));
      staging_ = make_memory(grown, true);
    }
  }
  const VkDeviceSize at = staging_used_;
  staging_used_ += need;
  return at;
}

void Runtime::record_copy(const DeviceMemory& src, VkDeviceSize src_offset, const DeviceMemory& dst,
                          VkDeviceSize dst_offset, VkDeviceSize bytes) {
  Command c;
  c.kind = Command::Kind::kCopy;
  c.src = src.buffer.get();
  c.dst = dst.buffer.get();
  c.src_offset = src_offset;
  c.dst_offset = dst_offset;
  c.bytes = bytes;
  c.ids = {src.id, dst.id};
  note_use(src.id);
  note_use(dst.id);
  pending_.push_back(std::move(c));
}

void Runtime::upload(Buffer& dst, std::size_t offset, const void* src, std::size_t bytes) {
  const DeviceMemory& m = vk(dst, "upload").memory();
  check_range(dst, offset, bytes, "upload");
  if (bytes == 0) return;
  // Unified memory that no pending command uses: the host writes it now, and the submit that
  // follows makes the write visible to the device.
  if (m.mapped != nullptr && !pending_uses(m.id)) {
    std::memcpy(static_cast<std::uint8_t*>(m.mapped) + offset, src, bytes);
    return;
  }
  const VkDeviceSize at = reserve_staging(bytes);
  std::memcpy(static_cast<std::uint8_t*>(staging_.mapped) + at, src, bytes);
  record_copy(staging_, at, m, offset, bytes);
}

void Runtime::download(const Buffer& src, std::size_t offset, void* dst, std::size_t bytes) {
  const DeviceMemory& m = vk(src, "download").memory();
  check_range(src, offset, bytes, "download");
  if (bytes == 0) return;
  if (m.mapped != nullptr) {
    if (pending_uses(m.id)) flush();
    std::memcpy(dst, static_cast<const std::uint8_t*>(m.mapped) + offset, bytes);
    return;
  }
  const VkDeviceSize at = reserve_staging(bytes);
  record_copy(m, offset, staging_, at, bytes);
  flush();
  std::memcpy(dst, static_cast<const std::uint8_t*>(staging_.mapped) + at, bytes);
}

void Runtime::fill(Buffer& dst, std::size_t offset, std::size_t bytes, std::uint8_t value) {
  const DeviceMemory& m = vk(dst, "fill").memory();
  check_range(dst, offset, bytes, "fill");
  if (bytes == 0) return;
  if (m.mapped != nullptr && !pending_uses(m.id)) {
    std::memset(static_cast<std::uint8_t*>(m.mapped) + offset, value, bytes);
    return;
  }
  // vkCmdFillBuffer writes whole aligned words; the bytes outside them go through fill_bytes.comp.
  const VkDeviceSize end = offset + bytes;
  const VkDeviceSize first_word = align_up(offset, 4);
  const VkDeviceSize last_word = end / 4 * 4;
  auto fill_bytes = [&](VkDeviceSize at, VkDeviceSize count) {
    if (count == 0) return;
    dispatch("fill_bytes", {&dst},
             FillBytesParams{static_cast<std::uint32_t>(at), static_cast<std::uint32_t>(count), value},
             Work::items(count));
  };
  if (first_word >= last_word) {
    fill_bytes(offset, bytes);
    return;
  }
  fill_bytes(offset, first_word - offset);
  Command c;
  c.kind = Command::Kind::kFill;
  c.dst = m.buffer.get();
  c.dst_offset = first_word;
  c.bytes = last_word - first_word;
  c.fill_word = 0x01010101u * value;
  c.ids = {m.id};
  note_use(m.id);
  pending_.push_back(std::move(c));
  fill_bytes(last_word, end - last_word);
}

// ---- Retiring memory -----------------------------------------------------------------------------

void Runtime::retire(DeviceMemory memory) noexcept {
  try {
    if (pending_uses(memory.id))
      garbage_.push_back(std::move(memory));  // freed once the batch that uses it has run
    else
      destroy_now(std::move(memory));
  } catch (...) {  // out of host memory while retiring: the memory is freed here, as a last resort
  }
}

void Runtime::destroy_now(DeviceMemory memory) {
  const VkDevice dev = ctx_->device();
  for (auto it = sets_.begin(); it != sets_.end();) {
    if (contains(it->first, memory.id, 1)) {
      vkFreeDescriptorSets(dev, it->second.pool, 1, &it->second.set);
      it = sets_.erase(it);
    } else {
      ++it;
    }
  }
  for (auto it = cache_.begin(); it != cache_.end();) {
    if (contains(it->ids, memory.id)) {
      vkFreeCommandBuffers(dev, command_pool_.get(), 1, &it->cmd);
      it = cache_.erase(it);
    } else {
      ++it;
    }
  }
  // `memory` is destroyed here.
}

void Runtime::collect_garbage() {
  std::vector<DeviceMemory> garbage = std::move(garbage_);
  garbage_.clear();
  for (auto& m : garbage) destroy_now(std::move(m));
}

// ---- Per-kernel timing ---------------------------------------------------------------------------

void Runtime::create_timestamp_pool() {
  std::uint32_t families = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(ctx_->physical(), &families, nullptr);
  std::vector<VkQueueFamilyProperties> props(families);
  vkGetPhysicalDeviceQueueFamilyProperties(ctx_->physical(), &families, props.data());
  const std::uint32_t bits = ctx_->queue_family() < families ? props[ctx_->queue_family()].timestampValidBits : 0;
  if (bits == 0 || !(ctx_->limits().timestampPeriod > 0.0f)) {
    throw BackendError("vulkan: per-kernel timing asked, but this device's compute queue writes no timestamps "
                       "(timestampValidBits " + std::to_string(bits) + ", timestampPeriod " +
                       std::to_string(ctx_->limits().timestampPeriod) + ")");
  }
  timestamp_mask_ = bits >= 64 ? ~0ull : (1ull << bits) - 1;
  timestamp_ns_ = ctx_->limits().timestampPeriod;
  auto info = make_info<VkQueryPoolCreateInfo>(VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO);
  info.queryType = VK_QUERY_TYPE_TIMESTAMP;
  info.queryCount = 2 * kMaxTimedDispatches;
  VkQueryPool pool = VK_NULL_HANDLE;
  check(vkCreateQueryPool(ctx_->device(), &info, nullptr, &pool), "vkCreateQueryPool", "kernel timestamps");
  timestamps_ = Unique<VkQueryPool>(ctx_->device(), pool, vkDestroyQueryPool);
}

void Runtime::read_timestamps() {
  std::vector<const Kernel*> timed;
  for (const Command& c : pending_) {
    if (c.kind == Command::Kind::kDispatch && timed.size() < kMaxTimedDispatches) timed.push_back(c.kernel);
  }
  if (timed.empty()) return;
  std::vector<std::uint64_t> ticks(2 * timed.size());
  check(vkGetQueryPoolResults(ctx_->device(), timestamps_.get(), 0, static_cast<std::uint32_t>(ticks.size()),
                              ticks.size() * sizeof(std::uint64_t), ticks.data(), sizeof(std::uint64_t),
                              VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
        "vkGetQueryPoolResults", "kernel timestamps");
  for (std::size_t d = 0; d < timed.size(); ++d) {
    const std::uint64_t ticks_run = (ticks[2 * d + 1] - ticks[2 * d]) & timestamp_mask_;
    profile_.add(timed[d]->name, static_cast<double>(ticks_run) * timestamp_ns_ * 1e-6);
  }
}

std::vector<KernelTime> Runtime::kernel_times(bool reset) {
  flush();
  return profile_.take(reset);
}

// ---- Batches -------------------------------------------------------------------------------------

std::vector<std::uint64_t> Runtime::signature() const {
  std::vector<std::uint64_t> s;
  s.reserve(pending_.size() * 16);
  for (const Command& c : pending_) {
    s.push_back(static_cast<std::uint64_t>(c.kind));
    s.push_back(c.ids.size());
    s.insert(s.end(), c.ids.begin(), c.ids.end());
    switch (c.kind) {
      case Command::Kind::kDispatch:
        s.push_back(c.kernel->index);
        s.push_back(c.params_offset);
        s.push_back(c.push_bytes);
        for (std::uint32_t i = 0; i < c.push_bytes / 4; ++i) s.push_back(c.push[i]);
        s.insert(s.end(), {c.groups[0], c.groups[1], c.groups[2]});
        break;
      case Command::Kind::kCopy:
        s.insert(s.end(), {c.src_offset, c.dst_offset, c.bytes});
        break;
      case Command::Kind::kFill:
        s.insert(s.end(), {c.dst_offset, c.bytes, c.fill_word});
        break;
    }
  }
  return s;
}

void Runtime::record(VkCommandBuffer cmd, bool one_time) {
  auto begin = make_info<VkCommandBufferBeginInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO);
  begin.flags = one_time ? VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT : 0;
  check(vkBeginCommandBuffer(cmd, &begin), "vkBeginCommandBuffer");
  // Each command may read what the one before wrote: a full compute/transfer barrier between
  // every two (DESIGN.md allows it; the frontend's kernels depend on each other in a chain).
  constexpr VkPipelineStageFlags kStages =
      VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT;
  auto between = make_info<VkMemoryBarrier>(VK_STRUCTURE_TYPE_MEMORY_BARRIER);
  between.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
  between.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT |
                          VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
  const Kernel* bound = nullptr;
  std::uint32_t dispatches = 0;  // timed so far
  if (timestamps_) {
    const auto timed = static_cast<std::uint32_t>(std::min<std::size_t>(
        kMaxTimedDispatches, std::count_if(pending_.begin(), pending_.end(), [](const Command& c) {
          return c.kind == Command::Kind::kDispatch;
        })));
    if (timed > 0) vkCmdResetQueryPool(cmd, timestamps_.get(), 0, 2 * timed);
  }
  for (std::size_t i = 0; i < pending_.size(); ++i) {
    const Command& c = pending_[i];
    if (i > 0) vkCmdPipelineBarrier(cmd, kStages, kStages, 0, 1, &between, 0, nullptr, 0, nullptr);
    switch (c.kind) {
      case Command::Kind::kDispatch: {
        const Kernel& k = *c.kernel;
        if (bound != &k) vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, k.pipeline.get());
        bound = &k;
        if (k.params_buffer) {
          const VkDescriptorSet sets[2] = {c.set, params_set_};
          vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, k.layout.get(), 0, 2, sets, 1,
                                  &c.params_offset);
        } else {
          vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, k.layout.get(), 0, 1, &c.set, 0,
                                  nullptr);
        }
        if (k.push && c.push_bytes > 0)
          vkCmdPushConstants(cmd, k.layout.get(), VK_SHADER_STAGE_COMPUTE_BIT, 0, c.push_bytes,
                             c.push.data());
        const bool timed = timestamps_ && dispatches < kMaxTimedDispatches;
        if (timed) vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, timestamps_.get(), 2 * dispatches);
        vkCmdDispatch(cmd, c.groups[0], c.groups[1], c.groups[2]);
        if (timed) {
          vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, timestamps_.get(), 2 * dispatches + 1);
          ++dispatches;
        }
        break;
      }
      case Command::Kind::kCopy: {
        const VkBufferCopy region{c.src_offset, c.dst_offset, c.bytes};
        vkCmdCopyBuffer(cmd, c.src, c.dst, 1, &region);
        break;
      }
      case Command::Kind::kFill:
        vkCmdFillBuffer(cmd, c.dst, c.dst_offset, c.bytes, c.fill_word);
        break;
    }
  }
  // Device writes become visible to the host once the fence has signalled.
  auto to_host = make_info<VkMemoryBarrier>(VK_STRUCTURE_TYPE_MEMORY_BARRIER);
  to_host.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
  to_host.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
  vkCmdPipelineBarrier(cmd, kStages, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &to_host, 0, nullptr, 0, nullptr);
  check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
}

void Runtime::flush() {
  if (pending_.empty()) {
    collect_garbage();
    return;
  }
  const VkDevice dev = ctx_->device();
  auto finish = [&] {
    pending_.clear();
    pending_ids_.clear();
    pending_dispatch_ = false;
    params_used_ = 0;
    staging_used_ = 0;
    collect_garbage();
  };
  try {
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    if (pending_dispatch_) {
      // A batch equal to an earlier one replays its command buffer (parameters in the parameter
      // buffer are read at execution, so only their offsets need to match).
      std::vector<std::uint64_t> sig = signature();
      ++batch_clock_;
      for (CachedBatch& cached : cache_) {
        if (cached.signature == sig) {
          cached.last_use = batch_clock_;
          cmd = cached.cmd;
          ++stats_.command_buffers_replayed;
          break;
        }
      }
      if (cmd == VK_NULL_HANDLE) {
        if (cache_.size() >= kMaxCachedBatches) {
          auto oldest = std::min_element(
              cache_.begin(), cache_.end(),
              [](const CachedBatch& a, const CachedBatch& b) { return a.last_use < b.last_use; });
          vkFreeCommandBuffers(dev, command_pool_.get(), 1, &oldest->cmd);
          cache_.erase(oldest);
        }
        auto info = make_info<VkCommandBufferAllocateInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO);
        info.commandPool = command_pool_.get();
        info.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
        info.commandBufferCount = 1;
        check(vkAllocateCommandBuffers(dev, &info, &cmd), "vkAllocateCommandBuffers", "a batch");
        try {
          record(cmd, false);
        } catch (...) {
          vkFreeCommandBuffers(dev, command_pool_.get(), 1, &cmd);
          throw;
        }
        ++stats_.command_buffers_recorded;
        cache_.push_back({std::move(sig), pending_ids_, cmd, batch_clock_});
      }
    } else {
      cmd = transfer_cmd_;  // copies and fills only: cheap to record, sizes vary
      record(cmd, true);
    }
    auto submit = make_info<VkSubmitInfo>(VK_STRUCTURE_TYPE_SUBMIT_INFO);
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &cmd;
    check(vkQueueSubmit(ctx_->queue(), 1, &submit, fence_.get()), "vkQueueSubmit");
    ++stats_.submits;
    const VkFence fence = fence_.get();
    check(vkWaitForFences(dev, 1, &fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
    check(vkResetFences(dev, 1, &fence), "vkResetFences");
    if (timestamps_) read_timestamps();
  } catch (...) {
    finish();
    throw;
  }
  finish();
  ctx_->throw_validation_errors("a submitted batch");
}

}  // namespace porta::vulkan
