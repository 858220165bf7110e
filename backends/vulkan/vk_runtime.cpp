// Memory and transfers of the Vulkan backend (vulkan_backend.hpp has the design). Streams, batches
// and their submission are in vk_streams.cpp; pipelines and descriptor sets in vk_pipelines.cpp.
#include "vulkan/vk_runtime.hpp"

#include <algorithm>
#include <cstring>
#include <string>

#include "vulkan/vk_errors.hpp"

namespace porta::vulkan {

namespace {

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

VulkanHostBuffer::VulkanHostBuffer(std::shared_ptr<Runtime> runtime, DeviceMemory memory, std::size_t bytes)
    : HostBuffer(static_cast<std::uint8_t*>(memory.mapped), bytes),
      runtime_(std::move(runtime)),
      memory_(std::move(memory)) {}

VulkanHostBuffer::~VulkanHostBuffer() { runtime_->retire(std::move(memory_)); }

Runtime::Runtime(const BackendOptions& options) : ctx_(std::make_unique<Context>(options)) {
  const VkDevice dev = ctx_->device();
  auto pool_info = make_info<VkCommandPoolCreateInfo>(VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO);
  pool_info.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pool_info.queueFamilyIndex = ctx_->queue_family();
  VkCommandPool pool = VK_NULL_HANDLE;
  check(vkCreateCommandPool(dev, &pool_info, nullptr, &pool), "vkCreateCommandPool");
  command_pool_ = Unique<VkCommandPool>(dev, pool, vkDestroyCommandPool);
  if (ctx_->separate_transfer_family()) {
    pool_info.queueFamilyIndex = ctx_->transfer_family();
    check(vkCreateCommandPool(dev, &pool_info, nullptr, &pool), "vkCreateCommandPool", "the transfer queue");
    transfer_pool_ = Unique<VkCommandPool>(dev, pool, vkDestroyCommandPool);
  }
  create_streams(options.profile_kernels);
}

Runtime::~Runtime() {
  // Running batches finish first; pending ones are dropped (they never ran).
  if (ctx_) {
    for (VkQueue q : ctx_->queues()) vkQueueWaitIdle(q);
    if (ctx_->transfer_queue() != VK_NULL_HANDLE) vkQueueWaitIdle(ctx_->transfer_queue());
  }
}

// ---- Memory --------------------------------------------------------------------------------------

DeviceMemory Runtime::make_memory(VkDeviceSize bytes, Place place) {
  const VkDevice dev = ctx_->device();
  DeviceMemory m;
  m.size = std::max<VkDeviceSize>(4, align_up(bytes, 4));  // vkCmdFillBuffer works on whole words
  m.id = next_id_++;
  auto info = make_info<VkBufferCreateInfo>(VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO);
  info.size = m.size;
  info.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT |
               VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  // Shared by the compute and the transfer family where they differ: uploads on the copy engines
  // write the kernels' buffers and read the host buffers with no ownership transfer.
  const std::uint32_t families[2] = {ctx_->queue_family(), ctx_->transfer_family()};
  if (ctx_->separate_transfer_family()) {
    info.sharingMode = VK_SHARING_MODE_CONCURRENT;
    info.queueFamilyIndexCount = 2;
    info.pQueueFamilyIndices = families;
  } else {
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  }
  const std::string what = std::to_string(bytes) + " bytes";
  VkBuffer buffer = VK_NULL_HANDLE;
  check(vkCreateBuffer(dev, &info, nullptr, &buffer), "vkCreateBuffer", what);
  m.buffer = Unique<VkBuffer>(dev, buffer, vkDestroyBuffer);

  VkMemoryRequirements req{};
  vkGetBufferMemoryRequirements(dev, buffer, &req);
  const MemoryChoice choice = place == Place::kHost     ? ctx_->host_memory(req.memoryTypeBits)
                              : place == Place::kParams ? ctx_->params_memory(req.memoryTypeBits)
                                                        : ctx_->device_memory(req.memoryTypeBits);
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
  DeviceMemory m = make_memory(bytes, Place::kDevice);
  ++stats_.buffers_allocated;
  if (m.mapped != nullptr) {
    std::memset(m.mapped, 0, m.size);
  } else {
    Command c;
    c.kind = Command::Kind::kFill;
    c.dst = m.buffer.get();
    c.bytes = m.size;
    c.ids = {m.id};
    c.writes = {m.id};
    Stream& s = current();
    begin_record(s);
    push_command(s, std::move(c));
  }
  return std::make_unique<VulkanBuffer>(shared_from_this(), std::move(m), bytes);
}

std::unique_ptr<HostBuffer> Runtime::allocate_host(std::size_t bytes) {
  DeviceMemory m = make_memory(bytes, Place::kHost);
  std::memset(m.mapped, 0, m.size);
  return std::make_unique<VulkanHostBuffer>(shared_from_this(), std::move(m), bytes);
}

const VulkanBuffer& Runtime::vk(const Buffer& b, const char* call) const {
  const auto* v = dynamic_cast<const VulkanBuffer*>(&b);
  if (v == nullptr || v->owner() != this)
    throw BackendError(std::string("vulkan: ") + call + ": the buffer was not made by this Vulkan backend");
  return *v;
}

const VulkanHostBuffer& Runtime::vk_host(const HostBuffer& b, const char* call) const {
  const auto* v = dynamic_cast<const VulkanHostBuffer*>(&b);
  if (v == nullptr || v->owner() != this)
    throw BackendError(std::string("vulkan: ") + call +
                       ": the host buffer was not made by this Vulkan backend's allocate_host()");
  return *v;
}

bool Runtime::in_use(std::uint64_t id) const {
  return std::any_of(streams_.begin(), streams_.end(), [id](const Stream& s) {
    return contains(s.pending_ids, id) || contains(s.running_ids, id);
  });
}

bool Runtime::written(std::uint64_t id) const {
  return std::any_of(streams_.begin(), streams_.end(), [id](const Stream& s) {
    return contains(s.pending_writes, id) || contains(s.running_writes, id);
  });
}

VkDeviceSize Runtime::reserve_staging(Stream& s, VkDeviceSize bytes) {
  const VkDeviceSize need = align_up(std::max<VkDeviceSize>(bytes, 1), 16);
  if (s.staging_used + need > s.staging.size) {
    if (s.staging_used > 0) {  // the batch's copies read or write the staging buffer
      finish_stream(static_cast<int>(&s - streams_.data()));
      begin_record(s);
    }
    if (need > s.staging.size) {
      const VkDeviceSize grown = std::max({kMinStaging, need, 2 * s.staging.size});
      if (s.staging.buffer) destroy_now(std::move(s.staging));
      s.staging = make_memory(grown, Place::kHost);
    }
  }
  const VkDeviceSize at = s.staging_used;
  s.staging_used += need;
  return at;
}

void Runtime::record_copy(Stream& s, const DeviceMemory& src, VkDeviceSize src_offset, const DeviceMemory& dst,
                          VkDeviceSize dst_offset, VkDeviceSize bytes) {
  Command c;
  c.kind = Command::Kind::kCopy;
  c.src = src.buffer.get();
  c.dst = dst.buffer.get();
  c.src_offset = src_offset;
  c.dst_offset = dst_offset;
  c.bytes = bytes;
  c.ids = {src.id, dst.id};
  c.writes = {dst.id};
  push_command(s, std::move(c));
}

void Runtime::upload(Buffer& dst, std::size_t offset, const void* src, std::size_t bytes) {
  const DeviceMemory& m = vk(dst, "upload").memory();
  check_range(dst, offset, bytes, "upload");
  if (bytes == 0) return;
  // Unified memory that no pending command uses: the host writes it now, and the submit that
  // follows makes the write visible to the device.
  if (m.mapped != nullptr && !in_use(m.id)) {
    std::memcpy(static_cast<std::uint8_t*>(m.mapped) + offset, src, bytes);
    return;
  }
  Stream& s = current();
  begin_record(s);
  const VkDeviceSize at = reserve_staging(s, bytes);
  std::memcpy(static_cast<std::uint8_t*>(s.staging.mapped) + at, src, bytes);
  record_copy(s, s.staging, at, m, offset, bytes);
}

void Runtime::download(const Buffer& src, std::size_t offset, void* dst, std::size_t bytes) {
  const DeviceMemory& m = vk(src, "download").memory();
  check_range(src, offset, bytes, "download");
  if (bytes == 0) return;
  if (m.mapped != nullptr) {
    if (in_use(m.id)) flush();
    std::memcpy(dst, static_cast<const std::uint8_t*>(m.mapped) + offset, bytes);
    return;
  }
  Stream& s = current();
  begin_record(s);
  const VkDeviceSize at = reserve_staging(s, bytes);
  record_copy(s, m, offset, s.staging, at, bytes);
  flush();
  std::memcpy(dst, static_cast<const std::uint8_t*>(s.staging.mapped) + at, bytes);
}

void Runtime::upload_async(Buffer& dst, std::size_t dst_offset, const HostBuffer& src, std::size_t src_offset,
                           std::size_t bytes) {
  check_host_range(src, src_offset, bytes, "vulkan", "upload_async");
  const DeviceMemory& from = vk_host(src, "upload_async").memory();
  const DeviceMemory& to = vk(dst, "upload_async").memory();
  check_range(dst, dst_offset, bytes, "upload_async");
  if (bytes == 0) return;
  Stream& s = current();
  begin_record(s);
  if (upload_on_transfer_queue(s, from, src_offset, to, dst_offset, bytes)) return;
  record_copy(s, from, src_offset, to, dst_offset, bytes);
}

bool Runtime::upload_on_transfer_queue(Stream& s, const DeviceMemory& from, VkDeviceSize src_offset,
                                       const DeviceMemory& to, VkDeviceSize dst_offset, VkDeviceSize bytes) {
  // In the stream's order the copy would wait for the work before it, and that work for the copies
  // of the frames merged with it: on the copy engines, a frame's input arrives while the kernels
  // of the frames before it run. It can leave that order only where no batch uses the destination
  // and none writes the source (batches that only read the source, as the uploads of earlier
  // frames from the same input image do, read it beside the copy).
  const VkQueue queue = ctx_->transfer_queue();
  if (queue == VK_NULL_HANDLE || written(from.id) || in_use(to.id)) return false;
  const VkDevice dev = ctx_->device();
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  if (!free_transfer_cmds_.empty()) {
    cmd = free_transfer_cmds_.back();
    free_transfer_cmds_.pop_back();
  } else {
    auto info = make_info<VkCommandBufferAllocateInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO);
    info.commandPool = transfer_pool_ ? transfer_pool_.get() : command_pool_.get();
    info.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    info.commandBufferCount = 1;
    check(vkAllocateCommandBuffers(dev, &info, &cmd), "vkAllocateCommandBuffers", "the transfer queue");
  }
  try {
    auto begin = make_info<VkCommandBufferBeginInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO);
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    check(vkBeginCommandBuffer(cmd, &begin), "vkBeginCommandBuffer", "the transfer queue");
    const VkBufferCopy region{src_offset, dst_offset, bytes};
    vkCmdCopyBuffer(cmd, from.buffer.get(), to.buffer.get(), 1, &region);
    check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer", "the transfer queue");
    // The semaphore makes the copy's writes visible to the batch that waits for it and to every
    // later command of the compute queue.
    const VkSemaphore done = take_semaphore();
    auto submit = make_info<VkSubmitInfo>(VK_STRUCTURE_TYPE_SUBMIT_INFO);
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &cmd;
    submit.signalSemaphoreCount = 1;
    submit.pSignalSemaphores = &done;
    check(vkQueueSubmit(queue, 1, &submit, VK_NULL_HANDLE), "vkQueueSubmit", "the transfer queue");
    transfers_.emplace_back(done, cmd);
    s.waits.push_back(done);
  } catch (...) {
    free_transfer_cmds_.push_back(cmd);
    throw;
  }
  // Both buffers stay in use until the batch that waits for the copy has run.
  note_use(s, from.id);
  note_use(s, to.id);
  note_write(s, to.id);
  ++stats_.transfer_queue_copies;
  return true;
}

void Runtime::recycle_transfers(const std::vector<VkSemaphore>& waited) {
  for (std::size_t i = transfers_.size(); i-- > 0;) {
    if (std::find(waited.begin(), waited.end(), transfers_[i].first) == waited.end()) continue;
    check(vkResetCommandBuffer(transfers_[i].second, 0), "vkResetCommandBuffer", "the transfer queue");
    free_transfer_cmds_.push_back(transfers_[i].second);
    transfers_.erase(transfers_.begin() + static_cast<std::ptrdiff_t>(i));
  }
}

void Runtime::download_async(const Buffer& src, std::size_t src_offset, HostBuffer& dst, std::size_t dst_offset,
                             std::size_t bytes) {
  check_host_range(dst, dst_offset, bytes, "vulkan", "download_async");
  const DeviceMemory& to = vk_host(dst, "download_async").memory();
  const DeviceMemory& from = vk(src, "download_async").memory();
  check_range(src, src_offset, bytes, "download_async");
  if (bytes == 0) return;
  Stream& s = current();
  begin_record(s);
  record_copy(s, from, src_offset, to, dst_offset, bytes);
}

void Runtime::fill(Buffer& dst, std::size_t offset, std::size_t bytes, std::uint8_t value) {
  const DeviceMemory& m = vk(dst, "fill").memory();
  check_range(dst, offset, bytes, "fill");
  if (bytes == 0) return;
  if (m.mapped != nullptr && !in_use(m.id)) {
    std::memset(static_cast<std::uint8_t*>(m.mapped) + offset, value, bytes);
    return;
  }
  Stream& s = current();
  begin_record(s);
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
  c.writes = {m.id};
  push_command(s, std::move(c));
  fill_bytes(last_word, end - last_word);
}

// ---- Retiring memory -----------------------------------------------------------------------------

void Runtime::retire(DeviceMemory memory) noexcept {
  try {
    if (in_use(memory.id))
      garbage_.push_back(std::move(memory));  // freed once the batches that use it have run
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
  for (Stream& s : streams_) {
    for (auto it = s.cache.begin(); it != s.cache.end();) {
      if (contains(it->ids, memory.id)) {
        vkFreeCommandBuffers(dev, command_pool_.get(), 1, &it->cmd);
        it = s.cache.erase(it);
      } else {
        ++it;
      }
    }
  }
  // `memory` is destroyed here.
}

void Runtime::collect_garbage() {
  std::vector<DeviceMemory> garbage = std::move(garbage_);
  garbage_.clear();
  for (auto& m : garbage) {
    if (in_use(m.id))
      garbage_.push_back(std::move(m));
    else
      destroy_now(std::move(m));
  }
}

}  // namespace porta::vulkan
