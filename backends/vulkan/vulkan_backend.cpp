#include "vulkan/vulkan_backend.hpp"

#include <chrono>
#include <cstdlib>
#include <string>

#include "porta/kernel_checks.hpp"
#include "vulkan/vk_context.hpp"
#include "vulkan/vk_runtime.hpp"

namespace porta::vulkan {

VulkanBackend::VulkanBackend(const BackendOptions& options) : runtime_(std::make_shared<Runtime>(options)) {
  // The workgroup kernels have up to 256 invocations, 32 x 8 in the tiled ones.
  const VkPhysicalDeviceLimits& limits = runtime_->context().limits();
  work_groups_ = !runtime_->context().cpu_device() && limits.maxComputeWorkGroupInvocations >= 256 &&
                 limits.maxComputeWorkGroupSize[0] >= 256 && limits.maxComputeWorkGroupSize[1] >= 8;
  work_groups_ = checks::env_switch("vulkan", "PORTA_VULKAN_WORK_GROUPS", work_groups_);
  // Off by default until measured on a GPU (the bytes are the suite's, on lavapipe).
  fused_pyramid_ = checks::env_switch("vulkan", "PORTA_VULKAN_FUSED_PYRAMID", false);
  // Detection in fewer dispatches (FAST with culling, PFA with compaction): each dispatch and
  // barrier saved is device time between kernels and host time recording them.
  fused_detect_ = checks::env_switch("vulkan", "PORTA_VULKAN_FUSED_DETECT",
                                     work_groups_ && limits.maxComputeWorkGroupInvocations >= 1024 &&
                                         limits.maxComputeWorkGroupSize[0] >= 1024);
  // How long the host polls a batch's fence before it blocks: on a GPU a blocking wait's wake-up
  // costs tens of microseconds; a CPU device needs the cores for the batch itself.
  runtime_->set_fence_poll(std::chrono::microseconds(checks::env_int(
      "vulkan", "PORTA_VULKAN_FENCE_POLL_US", 0, 1000000, runtime_->context().cpu_device() ? 0 : 1000,
      "a time in microseconds")));
  pfa_in_cull_ = checks::env_switch("vulkan", "PORTA_VULKAN_PFA_IN_CULL", true);
  fused_detect_finish_ = checks::env_switch("vulkan", "PORTA_VULKAN_CULL_FINISHES", true);
  cull_pixels_ = checks::env_int("vulkan", "PORTA_VULKAN_CULL_PIXELS", 0, 1024, 0, "a pixel count");
  runtime_->set_all_barriers(checks::env_switch("vulkan", "PORTA_VULKAN_ALL_BARRIERS", false));
  if (const char* env = std::getenv("PORTA_VULKAN_HOLD_BATCHES"); env != nullptr && *env != '\0') {
    const std::string value = env;
    if (value == "on" || value == "off") {
      runtime_->set_hold_depth(value == "on" ? Runtime::kDefaultHoldDepth : 0);
    } else {
      runtime_->set_hold_depth(checks::env_int("vulkan", "PORTA_VULKAN_HOLD_BATCHES", 1, Runtime::kMaxHoldDepth,
                                               Runtime::kDefaultHoldDepth, "on, off or a batch count"));
    }
  }
  queues_ = Runtime::kStreams;
  if (const char* env = std::getenv("PORTA_VULKAN_QUEUES"); env != nullptr && *env != '\0') {
    const std::string value = env;
    char* end = nullptr;
    const long n = std::strtol(env, &end, 10);
    if (end == env || *end != '\0' || n < 1 || n > Runtime::kStreams)
      throw BackendError("vulkan: PORTA_VULKAN_QUEUES must be a queue count from 1 to " +
                         std::to_string(Runtime::kStreams) + ", got '" + value + "'");
    queues_ = static_cast<int>(n);
  }
}

VulkanBackend::~VulkanBackend() {
  scratch_.clear();
  runtime_.reset();  // lives on while buffers it made do
}

std::string VulkanBackend::device_name() const { return runtime_->context().entry().name; }

std::unique_ptr<Buffer> VulkanBackend::allocate(std::size_t bytes) { return runtime_->allocate(bytes); }

void VulkanBackend::upload(Buffer& dst, std::size_t dst_offset, const void* src, std::size_t bytes) {
  runtime_->upload(dst, dst_offset, src, bytes);
}

void VulkanBackend::download(const Buffer& src, std::size_t src_offset, void* dst, std::size_t bytes) {
  runtime_->download(src, src_offset, dst, bytes);
}

void VulkanBackend::fill(Buffer& dst, std::size_t offset, std::size_t bytes, std::uint8_t value) {
  runtime_->fill(dst, offset, bytes, value);
}

void VulkanBackend::synchronize() { runtime_->flush(); }

void VulkanBackend::flush() { runtime_->start(); }

void VulkanBackend::use_queue(int queue) {
  check_queue_index(queue, "use_queue");
  runtime_->use_stream(queue);
}

void VulkanBackend::queue_wait(int other) {
  check_queue_index(other, "queue_wait");
  runtime_->stream_wait(other);
}

void VulkanBackend::finish_queue(int queue) {
  check_queue_index(queue, "finish_queue");
  runtime_->finish_stream(queue);
}

std::unique_ptr<HostBuffer> VulkanBackend::allocate_host(std::size_t bytes) { return runtime_->allocate_host(bytes); }

void VulkanBackend::upload_async(Buffer& dst, std::size_t dst_offset, const HostBuffer& src, std::size_t src_offset,
                                 std::size_t bytes) {
  runtime_->upload_async(dst, dst_offset, src, src_offset, bytes);
}

void VulkanBackend::download_async(const Buffer& src, std::size_t src_offset, HostBuffer& dst,
                                   std::size_t dst_offset, std::size_t bytes) {
  runtime_->download_async(src, src_offset, dst, dst_offset, bytes);
}

std::vector<KernelTime> VulkanBackend::kernel_times(bool reset) { return runtime_->kernel_times(reset); }

VulkanStats VulkanBackend::stats() const { return runtime_->stats(); }

bool VulkanBackend::validation_enabled() const { return runtime_->context().validation(); }

bool VulkanBackend::uploads_on_copy_engines() const { return runtime_->context().separate_transfer_family(); }

Buffer& VulkanBackend::scratch(const std::string& name, std::size_t bytes) {
  auto& slot = scratch_[{runtime_->current_stream(), name}];
  if (!slot || slot->size_bytes() < bytes) slot = allocate(bytes);
  return *slot;
}

}  // namespace porta::vulkan

namespace porta {

void register_vulkan_backend(BackendRegistry& registry) {
  registry.add(
      "vulkan",
      [] {
        BackendInfo info{"vulkan", true, false, {}};
        const vulkan::DeviceSurvey survey = vulkan::survey_devices();
        if (!survey.error.empty()) {
          info.detail = "no usable Vulkan driver: " + survey.error;
          return info;
        }
        if (survey.devices.empty()) {
          info.detail = "no Vulkan device found (no driver/ICD installed; e.g. Debian's mesa-vulkan-drivers)";
          return info;
        }
        for (const auto& d : survey.devices) info.available = info.available || d.missing.empty();
        info.detail = vulkan::list_devices(survey.devices);
        return info;
      },
      [](const BackendOptions& options) -> std::unique_ptr<Backend> {
        return std::make_unique<vulkan::VulkanBackend>(options);
      });
}

}  // namespace porta
