// The Vulkan context of one backend: instance (with the Khronos validation layer when asked for),
// the selected physical device, the logical device with its compute queue, and the memory types
// buffers are made from. Also the RAII wrapper every other Vulkan object of the backend lives in.
// Internal to backends/vulkan: nothing outside the backend sees a Vulkan type.
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "porta/registry.hpp"

namespace porta::vulkan {

/// Most queues the logical device may be created with ($PORTA_VULKAN_DEVICE_QUEUES; fewer where
/// the compute family has fewer). The default is one: on NVIDIA's driver, streams on queues of
/// their own ran 1.4-3x slower than on one queue (H200, docs/BENCHMARKS.md), as the GPU switches
/// between the queues rather than running them together.
inline constexpr std::uint32_t kMaxDeviceQueues = 8;
inline constexpr std::uint32_t kDefaultDeviceQueues = 1;

/// A Vulkan info struct with its sType set and every other member zero.
template <typename T>
T make_info(VkStructureType type) {
  T info{};
  info.sType = type;
  return info;
}

/// One owned handle of a device-level object, destroyed with `destroy(device, handle, nullptr)`.
/// Movable, not copyable (STYLE.md item 5).
template <typename T>
class Unique {
 public:
  using Destroy = void (*)(VkDevice, T, const VkAllocationCallbacks*);
  Unique() = default;
  Unique(VkDevice device, T handle, Destroy destroy) : device_(device), handle_(handle), destroy_(destroy) {}
  ~Unique() { reset(); }
  Unique(Unique&& o) noexcept { *this = std::move(o); }
  Unique& operator=(Unique&& o) noexcept {
    if (this != &o) {
      reset();
      device_ = std::exchange(o.device_, VK_NULL_HANDLE);
      handle_ = std::exchange(o.handle_, VK_NULL_HANDLE);
      destroy_ = std::exchange(o.destroy_, nullptr);
    }
    return *this;
  }
  Unique(const Unique&) = delete;
  Unique& operator=(const Unique&) = delete;

  T get() const { return handle_; }
  explicit operator bool() const { return handle_ != VK_NULL_HANDLE; }
  void reset() {
    if (handle_ != VK_NULL_HANDLE && destroy_ != nullptr) destroy_(device_, handle_, nullptr);
    handle_ = VK_NULL_HANDLE;
  }

 private:
  VkDevice device_ = VK_NULL_HANDLE;
  T handle_ = VK_NULL_HANDLE;
  Destroy destroy_ = nullptr;
};

/// One physical device as the selection sees it.
struct DeviceEntry {
  std::string name;  ///< VkPhysicalDeviceProperties::deviceName
  std::string type;  ///< "discrete GPU", "integrated GPU", "virtual GPU", "cpu", "other"
  std::uint32_t api_version = 0;
  std::string missing;  ///< why it cannot run the backend ("" when it can): the first missing feature
  std::string label() const { return name + " (" + type + ")"; }
};

/// The devices of this machine, or why there are none, without creating a backend (the probe).
struct DeviceSurvey {
  std::vector<DeviceEntry> devices;
  std::string error;  ///< set when no instance could be created (no loader/ICD) or enumeration failed
};
DeviceSurvey survey_devices();
/// "[0] llvmpipe (LLVM 15.0.6, 256 bits) (cpu); [1] ..." or "none".
std::string list_devices(const std::vector<DeviceEntry>& devices);

/// Where a buffer's memory lives and how the host reaches it.
struct MemoryChoice {
  std::uint32_t type_index = 0;
  bool mapped = false;  ///< host-visible, coherent and cached: the host reads and writes it directly
};

class Context {
 public:
  /// Creates the instance, selects the device (BackendOptions::device, else $PORTA_VULKAN_DEVICE,
  /// else the first discrete, integrated, virtual, then cpu device that has what the kernels need)
  /// and creates the logical device with kDefaultDeviceQueues queues of one compute family
  /// ($PORTA_VULKAN_DEVICE_QUEUES: up to kMaxDeviceQueues).
  explicit Context(const BackendOptions& options);
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  VkDevice device() const { return device_; }
  VkPhysicalDevice physical() const { return physical_; }
  /// The device's compute queues (at least one, at most kMaxDeviceQueues; one family).
  const std::vector<VkQueue>& queues() const { return queues_; }
  std::uint32_t queue_family() const { return queue_family_; }
  /// The queue upload_async() copies on, beside the compute queues, or VK_NULL_HANDLE (then the
  /// copies are commands of the compute batches). By default a queue of a transfer-only family (a
  /// GPU's copy engines) where the device has one, else none; $PORTA_VULKAN_TRANSFER_QUEUE=off:
  /// none; =on: also where the device has no such family, the first compute queue (separate
  /// submissions; how the tests cover it on lavapipe).
  VkQueue transfer_queue() const { return transfer_queue_; }
  std::uint32_t transfer_family() const { return transfer_family_; }
  /// The transfer queue is of another family than the compute queues: buffers are then shared by
  /// both families (VK_SHARING_MODE_CONCURRENT).
  bool separate_transfer_family() const {
    return transfer_queue_ != VK_NULL_HANDLE && transfer_family_ != queue_family_;
  }
  const VkPhysicalDeviceLimits& limits() const { return properties_.limits; }
  /// The device is a CPU (lavapipe): kernels with a workgroup per item cost more than they save
  /// there. $PORTA_VULKAN_WORK_GROUPS=on or off overrides (work_groups()).
  bool cpu_device() const { return properties_.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU; }
  const DeviceEntry& entry() const { return entry_; }
  bool validation() const { return messenger_ != VK_NULL_HANDLE; }

  /// Memory for kernel buffers: device-local where the device has it. `mapped` only when that
  /// memory is also host-visible, coherent and cached (unified memory, e.g. lavapipe) and
  /// $PORTA_VULKAN_STAGING is not 1 (which forces the staging path of discrete GPUs, for tests).
  MemoryChoice device_memory(std::uint32_t allowed_types) const;
  /// Host-visible coherent memory for staging and host buffers (cached when available).
  MemoryChoice host_memory(std::uint32_t allowed_types) const;
  /// Memory for the kernels' parameter blocks, which the host writes and every workgroup reads:
  /// device-local and host-visible where the device has it (a discrete GPU's BAR), so that the
  /// shaders do not read them across the bus; else host_memory(). $PORTA_VULKAN_PARAMS_MEMORY=host
  /// forces host_memory() (to measure the difference).
  MemoryChoice params_memory(std::uint32_t allowed_types) const;

  /// Throws BackendError with the validation layer's error messages since the last call, if any.
  void throw_validation_errors(const char* when);
  void add_validation_message(bool is_error, const std::string& text);

 private:
  VkInstance instance_ = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
  VkPhysicalDevice physical_ = VK_NULL_HANDLE;
  VkDevice device_ = VK_NULL_HANDLE;
  std::vector<VkQueue> queues_;
  std::uint32_t queue_family_ = 0;
  VkQueue transfer_queue_ = VK_NULL_HANDLE;
  std::uint32_t transfer_family_ = 0;
  VkPhysicalDeviceProperties properties_{};
  VkPhysicalDeviceMemoryProperties memory_{};
  DeviceEntry entry_;
  bool force_staging_ = false;
  std::vector<std::string> validation_errors_;
};

}  // namespace porta::vulkan
