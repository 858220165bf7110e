// The streams of the Vulkan backend (the HAL's queues): recording into a stream's pending batch,
// submitting it (replaying an equal batch's command buffer), the semaphores of stream_wait, the
// fences a stream's running batch is waited for with, and per-kernel timestamps.
// vulkan_backend.hpp has the design; memory and transfers are in vk_runtime.cpp.
#include <algorithm>
#include <chrono>
#include <cstring>
#include <string>

#include "vulkan/vk_errors.hpp"
#include "vulkan/vk_runtime.hpp"

namespace porta::vulkan {

namespace {

constexpr std::size_t kMaxCachedBatches = 16;  // per stream
/// Parameter bytes one batch may use before it is submitted to make room.
constexpr VkDeviceSize kParamsArea = 64 * 1024;
/// Every command may read what any before it wrote: compute and transfer, both ways.
constexpr VkPipelineStageFlags kStages = VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT;

bool contains(const std::vector<std::uint64_t>& v, std::uint64_t id) {
  return std::find(v.begin(), v.end(), id) != v.end();
}

}  // namespace

// ---- Creation ------------------------------------------------------------------------------------

void Runtime::create_streams(bool profile_kernels) {
  const VkDevice dev = ctx_->device();
  // The parameter buffers: one dynamic storage-buffer descriptor per stream, each dispatch at its
  // own offset.
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

  VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER_DYNAMIC, kStreams};
  auto pool_info = make_info<VkDescriptorPoolCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
  pool_info.maxSets = kStreams;
  pool_info.poolSizeCount = 1;
  pool_info.pPoolSizes = &size;
  VkDescriptorPool params_pool = VK_NULL_HANDLE;
  check(vkCreateDescriptorPool(dev, &pool_info, nullptr, &params_pool), "vkCreateDescriptorPool", "parameters");
  params_pool_ = Unique<VkDescriptorPool>(dev, params_pool, vkDestroyDescriptorPool);

  if (profile_kernels) {
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
  }

  streams_.resize(kStreams);
  const auto& queues = ctx_->queues();
  for (std::size_t i = 0; i < streams_.size(); ++i) {
    Stream& s = streams_[i];
    s.queue = queues[i % queues.size()];
    auto fence_info = make_info<VkFenceCreateInfo>(VK_STRUCTURE_TYPE_FENCE_CREATE_INFO);
    VkFence fence = VK_NULL_HANDLE;
    check(vkCreateFence(dev, &fence_info, nullptr, &fence), "vkCreateFence");
    s.fence = Unique<VkFence>(dev, fence, vkDestroyFence);

    auto cmd_info = make_info<VkCommandBufferAllocateInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO);
    cmd_info.commandPool = command_pool_.get();
    cmd_info.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    cmd_info.commandBufferCount = 1;
    check(vkAllocateCommandBuffers(dev, &cmd_info, &s.transfer_cmd), "vkAllocateCommandBuffers", "transfers");

    s.params = make_memory(kParamsArea + kMaxParamsBytes, Place::kParams);
    auto set_info = make_info<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
    set_info.descriptorPool = params_pool;
    set_info.descriptorSetCount = 1;
    set_info.pSetLayouts = &layout;
    check(vkAllocateDescriptorSets(dev, &set_info, &s.params_set), "vkAllocateDescriptorSets", "parameters");
    VkDescriptorBufferInfo buffer_info{s.params.buffer.get(), 0, kMaxParamsBytes};
    auto write = make_info<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
    write.dstSet = s.params_set;
    write.dstBinding = 0;
    write.descriptorCount = 1;
    write.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER_DYNAMIC;
    write.pBufferInfo = &buffer_info;
    vkUpdateDescriptorSets(dev, 1, &write, 0, nullptr);
    if (profile_kernels) s.timestamps = create_timestamp_pool();
  }
}

Unique<VkQueryPool> Runtime::create_timestamp_pool() {
  auto info = make_info<VkQueryPoolCreateInfo>(VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO);
  info.queryType = VK_QUERY_TYPE_TIMESTAMP;
  info.queryCount = 2 * kMaxTimedDispatches;
  VkQueryPool pool = VK_NULL_HANDLE;
  check(vkCreateQueryPool(ctx_->device(), &info, nullptr, &pool), "vkCreateQueryPool", "kernel timestamps");
  return Unique<VkQueryPool>(ctx_->device(), pool, vkDestroyQueryPool);
}

// ---- Recording -----------------------------------------------------------------------------------

void Runtime::begin_record(Stream& s) {
  // Work merged into another stream's batch runs before anything recorded now, and the staging
  // and parameter memory it reads are free only once it has run.
  if (s.carrier >= 0) finish_stream(s.carrier);
  if (s.pending.empty() && s.running) complete(s);
}

void Runtime::note_use(Stream& s, std::uint64_t id) {
  if (!contains(s.pending_ids, id)) s.pending_ids.push_back(id);
}

void Runtime::note_write(Stream& s, std::uint64_t id) {
  if (!contains(s.pending_writes, id)) s.pending_writes.push_back(id);
}

void Runtime::push_command(Stream& s, Command c) {
  for (const std::uint64_t id : c.ids) note_use(s, id);
  for (const std::uint64_t id : c.writes) note_write(s, id);
  if (c.kind == Command::Kind::kDispatch) s.pending_dispatch = true;
  // A barrier only where the command touches a buffer that a command of the current group (those
  // since the last barrier) writes, or writes one that such a command uses: commands on other
  // buffers run side by side (the blur beside detection). Buffer granularity: a kernel writing one
  // pyramid level and reading the one before waits for the level's writer.
  if (!all_barriers_ && !s.pending.empty()) {
    const auto touches = [](const std::vector<std::uint64_t>& a, const std::vector<std::uint64_t>& b) {
      for (const std::uint64_t id : a)
        if (contains(b, id)) return true;
      return false;
    };
    bool hazard = false;
    for (std::size_t i = s.pending.size(); i-- > 0 && !hazard;) {
      const Command& g = s.pending[i];
      hazard = touches(c.ids, g.writes) || touches(c.writes, g.ids);
      if (g.barrier_before) break;  // the group's first command
    }
    c.barrier_before = hazard;
  }
  s.pending.push_back(std::move(c));
}

void Runtime::dispatch_raw(const char* name, std::initializer_list<const Buffer*> buffers, const void* params,
                           std::uint32_t params_bytes, Work work) {
  const Clock::time_point started = streams_[static_cast<std::size_t>(current_)].timestamps ? Clock::now()
                                                                                             : Clock::time_point{};
  Command c;
  if (!make_dispatch(name, buffers, params_bytes, work, c)) return;
  Stream& s = current();
  begin_record(s);
  if (c.kernel->params_buffer) {
    const VkDeviceSize align = std::max<VkDeviceSize>(16, ctx_->limits().minStorageBufferOffsetAlignment);
    VkDeviceSize at = (s.params_used + align - 1) / align * align;
    if (at + kMaxParamsBytes > s.params.size) {  // this batch used the whole parameter area
      finish_stream(current_);
      at = 0;
    }
    std::memcpy(static_cast<std::uint8_t*>(s.params.mapped) + at, params, params_bytes);
    c.params_offset = static_cast<std::uint32_t>(at);
    c.params_stream = static_cast<std::uint8_t>(current_);
    s.params_used = at + params_bytes;
  } else if (c.kernel->push) {
    std::memcpy(c.push.data(), params, params_bytes);
    c.push_bytes = (params_bytes + 3) / 4 * 4;
  }
  const bool timed = static_cast<bool>(s.timestamps);
  push_command(s, std::move(c));
  if (timed) profile_.add_host(name, std::chrono::duration<double, std::milli>(Clock::now() - started).count());
}

// ---- Streams -------------------------------------------------------------------------------------

VkSemaphore Runtime::take_semaphore() {
  if (!free_semaphores_.empty()) {
    const VkSemaphore sem = free_semaphores_.back();
    free_semaphores_.pop_back();
    return sem;
  }
  auto info = make_info<VkSemaphoreCreateInfo>(VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO);
  VkSemaphore sem = VK_NULL_HANDLE;
  check(vkCreateSemaphore(ctx_->device(), &info, nullptr, &sem), "vkCreateSemaphore");
  semaphores_.emplace_back(ctx_->device(), sem, vkDestroySemaphore);
  return sem;
}

void Runtime::stream_wait(int other) {
  if (other == current_) return;  // a stream runs in order
  Stream& o = streams_[static_cast<std::size_t>(other)];
  if (o.carrier >= 0) {  // its work is in another stream's batch: wait for that one
    stream_wait(o.carrier);
    return;
  }
  if (!o.pending.empty() && o.queue == current().queue) {
    // On one device queue the two batches would run one after the other anyway (a barrier waits
    // for every earlier command of the queue); merged, their steps run side by side, and the
    // commands recorded from now on come after both.
    merge_pending(current_, other);
    return;
  }
  if (!o.pending.empty() || !o.waits.empty()) {
    const VkSemaphore sem = take_semaphore();
    submit(o, sem);
    current().waits.push_back(sem);
  } else if (o.running) {
    complete(o);  // already on the device without a semaphore: the host waits for it
  }
}

void Runtime::finish_stream(int stream) {
  Stream& s = streams_[static_cast<std::size_t>(stream)];
  if (s.carrier >= 0) finish_stream(s.carrier);  // its work is in that batch (and is free after it)
  if (!s.pending.empty() || !s.waits.empty()) submit(s, VK_NULL_HANDLE);
  complete(s);
  ctx_->throw_validation_errors("a submitted batch");
}

int Runtime::queue_backlog(VkQueue queue) {
  int n = 0;
  for (const Stream& t : streams_)
    if (t.running && t.queue == queue && vkGetFenceStatus(ctx_->device(), t.fence.get()) == VK_NOT_READY) ++n;
  return n;
}

bool Runtime::queued_behind(const Stream& s) {
  for (const Stream& t : streams_)
    if (&t != &s && t.running && t.queue == s.queue && t.submitted > s.submitted &&
        vkGetFenceStatus(ctx_->device(), t.fence.get()) == VK_NOT_READY)
      return true;
  return false;
}

void Runtime::start(bool hold) {
  // While the device has hold_depth_ batches of a queue still to run, a flushed batch for that
  // queue is held back, and the batches of later start()s on it are merged into it (their steps
  // side by side, as merge_pending does for a stereo pair): frames in flight then share barriers
  // instead of each waiting for every earlier frame's. At depth 1 (the default) a batch is held
  // while one runs; at depth 2 the device also has the next one queued behind it. A wait on the
  // host that would leave the device without work submits the held batch first (complete).
  const bool may_hold = hold && hold_depth_ > 0;
  for (std::size_t i = 0; i < streams_.size(); ++i) {
    Stream& s = streams_[i];
    const int index = static_cast<int>(i);
    if ((s.pending.empty() && s.waits.empty()) || index == held_) continue;
    if (may_hold && held_ >= 0 && streams_[static_cast<std::size_t>(held_)].queue == s.queue) {
      merge_pending(held_, index);
      ++stats_.held_batches;
      continue;
    }
    if (may_hold && held_ < 0 && queue_backlog(s.queue) >= hold_depth_) {
      held_ = index;
      ++stats_.held_batches;
      continue;
    }
    submit(s, VK_NULL_HANDLE);
  }
  if (held_ >= 0 &&
      !(may_hold && queue_backlog(streams_[static_cast<std::size_t>(held_)].queue) >= hold_depth_))
    submit_held();
}

void Runtime::submit_held() {
  if (held_ < 0) return;
  Stream& s = streams_[static_cast<std::size_t>(held_)];
  held_ = -1;
  submit(s, VK_NULL_HANDLE);
}

void Runtime::flush() {
  start(/*hold=*/false);
  for (Stream& s : streams_) complete(s);
  collect_garbage();
  ctx_->throw_validation_errors("a submitted batch");
}

std::vector<KernelTime> Runtime::kernel_times(bool reset) {
  flush();
  return profile_.take(reset);
}

void Runtime::merge_pending(int into, int from) {
  Stream& a = streams_[static_cast<std::size_t>(into)];
  Stream& b = streams_[static_cast<std::size_t>(from)];
  begin_record(a);  // its earlier batch has run: the merged one is recorded fresh
  // The groups of a command list: [start, end) ranges, a new one at each command with a barrier.
  const auto groups = [](const std::vector<Command>& v) {
    std::vector<std::pair<std::size_t, std::size_t>> g;
    for (std::size_t i = 0; i < v.size(); ++i) {
      if (i == 0 || v[i].barrier_before) g.emplace_back(i, i);
      g.back().second = i + 1;
    }
    return g;
  };
  const auto ga = groups(a.pending), gb = groups(b.pending);
  std::vector<Command> merged;
  merged.reserve(a.pending.size() + b.pending.size());
  for (std::size_t k = 0; k < std::max(ga.size(), gb.size()); ++k) {
    const std::size_t first = merged.size();
    if (k < ga.size())
      for (std::size_t i = ga[k].first; i < ga[k].second; ++i) merged.push_back(std::move(a.pending[i]));
    if (k < gb.size())
      for (std::size_t i = gb[k].first; i < gb[k].second; ++i) merged.push_back(std::move(b.pending[i]));
    for (std::size_t i = first; i < merged.size(); ++i) merged[i].barrier_before = i == first && k > 0;
  }
  // Everything recorded later waits for both.
  a.pending = std::move(merged);
  for (const std::uint64_t id : b.pending_ids) note_use(a, id);
  for (const std::uint64_t id : b.pending_writes) note_write(a, id);
  a.pending_dispatch = a.pending_dispatch || b.pending_dispatch;
  a.waits.insert(a.waits.end(), b.waits.begin(), b.waits.end());
  b.pending.clear();
  b.pending_ids.clear();
  b.pending_writes.clear();
  b.pending_dispatch = false;
  b.waits.clear();
  // b's staging and parameters stay reserved (b.params_used, b.staging_used) until a's batch has
  // run; so do those of streams b carried.
  b.carrier = into;
  for (Stream& t : streams_)
    if (t.carrier == from) t.carrier = into;
  if (held_ == from) held_ = -1;  // its work now waits in `into`, which its own start() submits or holds
  ++stats_.merged_batches;
}

void Runtime::release_carried(int carrier) {
  for (Stream& t : streams_) {
    if (t.carrier != carrier) continue;
    t.carrier = -1;
    t.params_used = 0;
    t.staging_used = 0;
  }
}

void Runtime::drop_pending(Stream& s) {
  if (held_ == static_cast<int>(&s - streams_.data())) held_ = -1;
  release_carried(static_cast<int>(&s - streams_.data()));
  s.pending.clear();
  s.pending_ids.clear();
  s.pending_writes.clear();
  s.pending_dispatch = false;
  s.waits.clear();  // left signalled, never reused
  s.params_used = 0;
  s.staging_used = 0;
}

void Runtime::submit(Stream& s, VkSemaphore signal) {
  if (held_ == static_cast<int>(&s - streams_.data())) held_ = -1;
  if (s.running) complete(s);
  const Clock::time_point started = s.timestamps ? Clock::now() : Clock::time_point{};
  try {
    const VkCommandBuffer cmd = s.pending.empty() ? VK_NULL_HANDLE : command_buffer_for(s);
    const std::vector<VkPipelineStageFlags> wait_stages(s.waits.size(), kStages);
    auto submit = make_info<VkSubmitInfo>(VK_STRUCTURE_TYPE_SUBMIT_INFO);
    submit.waitSemaphoreCount = static_cast<std::uint32_t>(s.waits.size());
    submit.pWaitSemaphores = s.waits.data();
    submit.pWaitDstStageMask = wait_stages.data();
    submit.commandBufferCount = cmd == VK_NULL_HANDLE ? 0 : 1;
    submit.pCommandBuffers = &cmd;
    submit.signalSemaphoreCount = signal == VK_NULL_HANDLE ? 0 : 1;
    submit.pSignalSemaphores = &signal;
    check(vkQueueSubmit(s.queue, 1, &submit, s.fence.get()), "vkQueueSubmit");
  } catch (...) {
    drop_pending(s);
    throw;
  }
  ++stats_.submits;
  s.running = true;
  s.submitted = ++submit_clock_;
  s.running_ids = std::move(s.pending_ids);
  s.running_writes = std::move(s.pending_writes);
  s.running_timed.clear();
  if (s.timestamps) {
    for (const Command& c : s.pending)
      if (c.kind == Command::Kind::kDispatch && s.running_timed.size() < kMaxTimedDispatches)
        s.running_timed.push_back(c.kernel);
  }
  s.running_waits = std::move(s.waits);
  s.waits.clear();
  s.pending_ids.clear();
  s.pending_writes.clear();
  s.pending.clear();
  s.pending_dispatch = false;
  s.params_used = 0;
  s.staging_used = 0;
  if (s.timestamps)
    profile_.add_host("(submit)", std::chrono::duration<double, std::milli>(Clock::now() - started).count(), true);
}

void Runtime::complete(Stream& s) {
  if (!s.running) return;
  if (held_ >= 0) {
    // The device works on the held batch while the host waits, unless it has work queued behind
    // this batch anyway (then later frames may still merge into the held one) or has run it.
    const Stream& h = streams_[static_cast<std::size_t>(held_)];
    if (h.queue != s.queue ||
        (vkGetFenceStatus(ctx_->device(), s.fence.get()) == VK_NOT_READY && !queued_behind(s)))
      submit_held();
  }
  s.running = false;  // also when the wait fails: the error is reported once
  const VkFence fence = s.fence.get();
  const VkDevice dev = ctx_->device();
  wait_for(fence);
  check(vkResetFences(dev, 1, &fence), "vkResetFences");
  if (!transfers_.empty()) recycle_transfers(s.running_waits);
  free_semaphores_.insert(free_semaphores_.end(), s.running_waits.begin(), s.running_waits.end());
  s.running_waits.clear();
  s.running_ids.clear();
  s.running_writes.clear();
  release_carried(static_cast<int>(&s - streams_.data()));
  if (s.timestamps) read_timestamps(s);
  collect_garbage();
}

void Runtime::wait_for(VkFence fence) {
  const VkDevice dev = ctx_->device();
  // The host polls the fence for a while first (on GPUs, by default): a blocking wait sleeps, and
  // waking up costs tens of microseconds, about as much as a whole small frame.
  if (fence_poll_.count() > 0) {
    const auto until = std::chrono::steady_clock::now() + fence_poll_;
    VkResult r = VK_NOT_READY;
    while ((r = vkGetFenceStatus(dev, fence)) == VK_NOT_READY && std::chrono::steady_clock::now() < until) {
    }
    if (r == VK_SUCCESS) return;
    if (r != VK_NOT_READY) check(r, "vkGetFenceStatus");
  }
  check(vkWaitForFences(dev, 1, &fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
}

// ---- Batches -------------------------------------------------------------------------------------

std::vector<std::uint64_t> Runtime::signature(const Stream& s) const {
  std::vector<std::uint64_t> sig;
  sig.reserve(s.pending.size() * 16);
  for (const Command& c : s.pending) {
    sig.push_back(static_cast<std::uint64_t>(c.kind) | (c.barrier_before ? 0x100u : 0u) |
                  (static_cast<std::uint64_t>(c.params_stream) << 16));
    sig.push_back(c.ids.size());
    sig.insert(sig.end(), c.ids.begin(), c.ids.end());
    switch (c.kind) {
      case Command::Kind::kDispatch:
        sig.push_back(c.kernel->index);
        sig.push_back(c.params_offset);
        sig.push_back(c.push_bytes);
        for (std::uint32_t i = 0; i < c.push_bytes / 4; ++i) sig.push_back(c.push[i]);
        sig.insert(sig.end(), {c.groups[0], c.groups[1], c.groups[2]});
        break;
      case Command::Kind::kCopy:
        sig.insert(sig.end(), {c.src_offset, c.dst_offset, c.bytes});
        break;
      case Command::Kind::kFill:
        sig.insert(sig.end(), {c.dst_offset, c.bytes, c.fill_word});
        break;
    }
  }
  return sig;
}

VkCommandBuffer Runtime::command_buffer_for(Stream& s) {
  if (!s.pending_dispatch) {
    record(s, s.transfer_cmd, true);  // copies and fills only: cheap to record, sizes vary
    return s.transfer_cmd;
  }
  // A batch equal to an earlier one of this stream replays its command buffer (parameters in the
  // parameter buffer are read at execution, so only their offsets need to match).
  std::vector<std::uint64_t> sig = signature(s);
  ++batch_clock_;
  for (CachedBatch& cached : s.cache) {
    if (cached.signature == sig) {
      cached.last_use = batch_clock_;
      ++stats_.command_buffers_replayed;
      return cached.cmd;
    }
  }
  const VkDevice dev = ctx_->device();
  if (s.cache.size() >= kMaxCachedBatches) {
    auto oldest = std::min_element(s.cache.begin(), s.cache.end(), [](const CachedBatch& a, const CachedBatch& b) {
      return a.last_use < b.last_use;
    });
    vkFreeCommandBuffers(dev, command_pool_.get(), 1, &oldest->cmd);
    s.cache.erase(oldest);
  }
  auto info = make_info<VkCommandBufferAllocateInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO);
  info.commandPool = command_pool_.get();
  info.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  info.commandBufferCount = 1;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  check(vkAllocateCommandBuffers(dev, &info, &cmd), "vkAllocateCommandBuffers", "a batch");
  try {
    record(s, cmd, false);
  } catch (...) {
    vkFreeCommandBuffers(dev, command_pool_.get(), 1, &cmd);
    throw;
  }
  ++stats_.command_buffers_recorded;
  s.cache.push_back({std::move(sig), s.pending_ids, cmd, batch_clock_});
  return cmd;
}

void Runtime::record(const Stream& s, VkCommandBuffer cmd, bool one_time) {
  auto begin = make_info<VkCommandBufferBeginInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO);
  begin.flags = one_time ? VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT : 0;
  check(vkBeginCommandBuffer(cmd, &begin), "vkBeginCommandBuffer");
  // A command may read what the ones before it wrote: a barrier wherever one touches the buffers
  // of the group before it (push_command; between every two with $PORTA_VULKAN_ALL_BARRIERS=on),
  // none between commands merged side by side (merge_pending). Its stages and accesses are set per
  // barrier below.
  auto between = make_info<VkMemoryBarrier>(VK_STRUCTURE_TYPE_MEMORY_BARRIER);
  between.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
  between.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT |
                          VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
  // In front: what earlier batches wrote is available (their fence, or the semaphore this batch
  // waits for, made it so) and becomes visible here. It waits for no earlier command, so batches of
  // other streams on the same queue are not drained by it.
  auto visible = make_info<VkMemoryBarrier>(VK_STRUCTURE_TYPE_MEMORY_BARRIER);
  visible.dstAccessMask = between.dstAccessMask;
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, kStages, 0, 1, &visible, 0, nullptr, 0, nullptr);
  const Kernel* bound = nullptr;
  std::uint32_t dispatches = 0;  // timed so far
  if (s.timestamps) {
    const auto timed = static_cast<std::uint32_t>(std::min<std::size_t>(
        kMaxTimedDispatches, std::count_if(s.pending.begin(), s.pending.end(), [](const Command& c) {
          return c.kind == Command::Kind::kDispatch;
        })));
    if (timed > 0) vkCmdResetQueryPool(cmd, s.timestamps.get(), 0, 2 * timed);
  }
  // The stages and accesses of a command, for the barriers around it: each barrier waits for the
  // stages of the group before it (the commands since the barrier before) and blocks those of the
  // group after it, so that consecutive barriers chain; a write made available by one is made
  // visible by any later one.
  const auto stage_of = [](const Command& c) {
    return c.kind == Command::Kind::kDispatch ? VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT : VK_PIPELINE_STAGE_TRANSFER_BIT;
  };
  const auto writes_of = [](const Command& c) {
    return c.kind == Command::Kind::kDispatch ? VK_ACCESS_SHADER_WRITE_BIT : VK_ACCESS_TRANSFER_WRITE_BIT;
  };
  const auto accesses_of = [](const Command& c) -> VkAccessFlags {
    return c.kind == Command::Kind::kDispatch ? VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT
                                              : VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
  };
  VkPipelineStageFlags group_stages = 0;  // of the commands since the last barrier
  VkAccessFlags group_writes = 0;
  for (std::size_t i = 0; i < s.pending.size(); ++i) {
    const Command& c = s.pending[i];
    if (i > 0 && c.barrier_before) {
      VkPipelineStageFlags next_stages = 0;
      VkAccessFlags next_accesses = 0;
      for (std::size_t j = i; j < s.pending.size() && (j == i || !s.pending[j].barrier_before); ++j) {
        next_stages |= stage_of(s.pending[j]);
        next_accesses |= accesses_of(s.pending[j]);
      }
      between.srcAccessMask = group_writes;
      between.dstAccessMask = next_accesses;
      vkCmdPipelineBarrier(cmd, group_stages, next_stages, 0, 1, &between, 0, nullptr, 0, nullptr);
      ++stats_.barriers_recorded;
      group_stages = 0;
      group_writes = 0;
    }
    group_stages |= stage_of(c);
    group_writes |= writes_of(c);
    ++stats_.commands_recorded;
    switch (c.kind) {
      case Command::Kind::kDispatch: {
        const Kernel& k = *c.kernel;
        if (bound != &k) vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, k.pipeline.get());
        bound = &k;
        if (k.params_buffer) {
          const VkDescriptorSet sets[2] = {c.set, streams_[c.params_stream].params_set};
          vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, k.layout.get(), 0, 2, sets, 1,
                                  &c.params_offset);
        } else {
          vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, k.layout.get(), 0, 1, &c.set, 0,
                                  nullptr);
        }
        if (k.push && c.push_bytes > 0)
          vkCmdPushConstants(cmd, k.layout.get(), VK_SHADER_STAGE_COMPUTE_BIT, 0, c.push_bytes, c.push.data());
        const bool timed = s.timestamps && dispatches < kMaxTimedDispatches;
        if (timed)
          vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, s.timestamps.get(), 2 * dispatches);
        vkCmdDispatch(cmd, c.groups[0], c.groups[1], c.groups[2]);
        if (timed) {
          vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, s.timestamps.get(), 2 * dispatches + 1);
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

// ---- Per-kernel timing ---------------------------------------------------------------------------

void Runtime::read_timestamps(Stream& s) {
  const std::vector<const Kernel*> timed = std::move(s.running_timed);
  s.running_timed.clear();
  if (timed.empty()) return;
  std::vector<std::uint64_t> ticks(2 * timed.size());
  check(vkGetQueryPoolResults(ctx_->device(), s.timestamps.get(), 0, static_cast<std::uint32_t>(ticks.size()),
                              ticks.size() * sizeof(std::uint64_t), ticks.data(), sizeof(std::uint64_t),
                              VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
        "vkGetQueryPoolResults", "kernel timestamps");
  for (std::size_t d = 0; d < timed.size(); ++d) {
    const std::uint64_t ticks_run = (ticks[2 * d + 1] - ticks[2 * d]) & timestamp_mask_;
    profile_.add(timed[d]->name, static_cast<double>(ticks_run) * timestamp_ns_ * 1e-6);
  }
}

}  // namespace porta::vulkan
