#include "vulkan/vk_context.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <sstream>

#include "porta/backend.hpp"
#include "porta/kernel_checks.hpp"
#include "vulkan/vk_errors.hpp"

namespace porta::vulkan {

namespace {

constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";

std::string env(const char* name) {
  const char* v = std::getenv(name);
  return v != nullptr ? std::string(v) : std::string();
}

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string version_text(std::uint32_t v) {
  return std::to_string(VK_API_VERSION_MAJOR(v)) + "." + std::to_string(VK_API_VERSION_MINOR(v));
}

const char* type_text(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
      return "discrete GPU";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
      return "integrated GPU";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
      return "virtual GPU";
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
      return "cpu";
    default:
      return "other";
  }
}

int type_rank(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
      return 0;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
      return 1;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
      return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
      return 3;
    default:
      return 4;
  }
}

std::vector<VkExtensionProperties> instance_extensions(const char* layer) {
  std::uint32_t n = 0;
  if (vkEnumerateInstanceExtensionProperties(layer, &n, nullptr) != VK_SUCCESS) return {};
  std::vector<VkExtensionProperties> out(n);
  if (vkEnumerateInstanceExtensionProperties(layer, &n, out.data()) != VK_SUCCESS) return {};
  out.resize(n);
  return out;
}

bool has_extension(const std::vector<VkExtensionProperties>& list, const char* name) {
  return std::any_of(list.begin(), list.end(),
                     [&](const VkExtensionProperties& e) { return std::strcmp(e.extensionName, name) == 0; });
}

std::vector<VkExtensionProperties> device_extensions(VkPhysicalDevice d) {
  std::uint32_t n = 0;
  if (vkEnumerateDeviceExtensionProperties(d, nullptr, &n, nullptr) != VK_SUCCESS) return {};
  std::vector<VkExtensionProperties> out(n);
  if (vkEnumerateDeviceExtensionProperties(d, nullptr, &n, out.data()) != VK_SUCCESS) return {};
  out.resize(n);
  return out;
}

bool layer_installed(const char* name) {
  std::uint32_t n = 0;
  if (vkEnumerateInstanceLayerProperties(&n, nullptr) != VK_SUCCESS) return false;
  std::vector<VkLayerProperties> layers(n);
  if (vkEnumerateInstanceLayerProperties(&n, layers.data()) != VK_SUCCESS) return false;
  return std::any_of(layers.begin(), layers.begin() + n,
                     [&](const VkLayerProperties& l) { return std::strcmp(l.layerName, name) == 0; });
}

/// The Vulkan version the instance asks for: 1.2 where the loader has it (so that 8-bit storage is
/// core on 1.2 devices), else 1.1; 0 when the loader is a 1.0 one.
std::uint32_t instance_api_version() {
  std::uint32_t v = VK_API_VERSION_1_0;
  if (vkEnumerateInstanceVersion(&v) != VK_SUCCESS) return 0;
  if (v >= VK_API_VERSION_1_2) return VK_API_VERSION_1_2;
  if (v >= VK_API_VERSION_1_1) return VK_API_VERSION_1_1;
  return 0;
}

VKAPI_ATTR VkBool32 VKAPI_CALL on_validation_message(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                     VkDebugUtilsMessageTypeFlagsEXT /*types*/,
                                                     const VkDebugUtilsMessengerCallbackDataEXT* data,
                                                     void* user) {
  const bool is_error = (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) != 0;
  static_cast<Context*>(user)->add_validation_message(
      is_error, data != nullptr && data->pMessage ? data->pMessage : "?");
  return VK_FALSE;
}

struct Instance {
  VkInstance instance = VK_NULL_HANDLE;
  std::uint32_t api_version = 0;
  bool debug_utils = false;
};

/// Creates the instance; `validation` enables the Khronos layer and VK_EXT_debug_utils.
Instance create_instance(bool validation) {
  Instance out;
  out.api_version = instance_api_version();
  if (out.api_version == 0)
    throw BackendError("vulkan: the Vulkan loader supports only Vulkan 1.0; PortaSLAM needs 1.1 or later");
  auto app = make_info<VkApplicationInfo>(VK_STRUCTURE_TYPE_APPLICATION_INFO);
  app.pApplicationName = "PortaSLAM";
  app.pEngineName = "PortaSLAM";
  app.apiVersion = out.api_version;

  std::vector<const char*> extensions;
  std::vector<const char*> layers;
  auto info = make_info<VkInstanceCreateInfo>(VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO);
  const auto available = instance_extensions(nullptr);
  // Devices behind a portability layer (MoltenVK) are listed only when the application asks.
  if (has_extension(available, VK_KHR_PORTABILITY_ENUMERATION_EXTENSION_NAME)) {
    extensions.push_back(VK_KHR_PORTABILITY_ENUMERATION_EXTENSION_NAME);
    info.flags |= VK_INSTANCE_CREATE_ENUMERATE_PORTABILITY_BIT_KHR;
  }
  if (validation) {
    layers.push_back(kValidationLayer);
    if (has_extension(available, VK_EXT_DEBUG_UTILS_EXTENSION_NAME) ||
        has_extension(instance_extensions(kValidationLayer), VK_EXT_DEBUG_UTILS_EXTENSION_NAME)) {
      extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
      out.debug_utils = true;
    }
  }
  info.pApplicationInfo = &app;
  info.enabledExtensionCount = static_cast<std::uint32_t>(extensions.size());
  info.ppEnabledExtensionNames = extensions.data();
  info.enabledLayerCount = static_cast<std::uint32_t>(layers.size());
  info.ppEnabledLayerNames = layers.data();
  check(vkCreateInstance(&info, nullptr, &out.instance), "vkCreateInstance",
        validation ? "with VK_LAYER_KHRONOS_validation" : "");
  return out;
}

std::vector<VkPhysicalDevice> physical_devices(VkInstance instance) {
  std::uint32_t n = 0;
  check(vkEnumeratePhysicalDevices(instance, &n, nullptr), "vkEnumeratePhysicalDevices");
  std::vector<VkPhysicalDevice> out(n);
  if (n > 0) check(vkEnumeratePhysicalDevices(instance, &n, out.data()), "vkEnumeratePhysicalDevices");
  out.resize(n);
  return out;
}

/// The first queue family with compute, or -1.
int compute_family(VkPhysicalDevice d) {
  std::uint32_t n = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(d, &n, nullptr);
  std::vector<VkQueueFamilyProperties> families(n);
  vkGetPhysicalDeviceQueueFamilyProperties(d, &n, families.data());
  for (std::uint32_t i = 0; i < n; ++i)
    if ((families[i].queueFlags & VK_QUEUE_COMPUTE_BIT) != 0 && families[i].queueCount > 0)
      return static_cast<int>(i);
  return -1;
}

/// A queue family that copies and does nothing else (a GPU's copy engines), or -1.
int transfer_only_family(VkPhysicalDevice d) {
  std::uint32_t n = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(d, &n, nullptr);
  std::vector<VkQueueFamilyProperties> families(n);
  vkGetPhysicalDeviceQueueFamilyProperties(d, &n, families.data());
  constexpr VkQueueFlags kOther = VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT;
  for (std::uint32_t i = 0; i < n; ++i)
    if ((families[i].queueFlags & VK_QUEUE_TRANSFER_BIT) != 0 && (families[i].queueFlags & kOther) == 0 &&
        families[i].queueCount > 0)
      return static_cast<int>(i);
  return -1;
}

/// What the kernels need of a device (DESIGN.md §3 on Vulkan): 8- and 16-bit storage buffers for
/// images and responses, 64-bit integers for the PFA projection, a compute queue, Vulkan 1.1.
struct Requirements {
  std::uint32_t api_version = 0;  ///< min(instance, device)
  bool needs_8bit_extension = false;
  bool has_portability_subset = false;
  std::string missing;
};

Requirements check_requirements(VkPhysicalDevice d, std::uint32_t instance_api) {
  Requirements r;
  VkPhysicalDeviceProperties props{};
  vkGetPhysicalDeviceProperties(d, &props);
  r.api_version = std::min(instance_api, props.apiVersion);
  const auto extensions = device_extensions(d);
  r.has_portability_subset = has_extension(extensions, "VK_KHR_portability_subset");
  if (VK_API_VERSION_MAJOR(r.api_version) == 1 && VK_API_VERSION_MINOR(r.api_version) < 1) {
    r.missing = "Vulkan 1.1 (the device supports " + version_text(props.apiVersion) + ")";
    return r;
  }
  if (compute_family(d) < 0) {
    r.missing = "a compute queue";
    return r;
  }
  r.needs_8bit_extension = r.api_version < VK_API_VERSION_1_2;
  if (r.needs_8bit_extension && !has_extension(extensions, VK_KHR_8BIT_STORAGE_EXTENSION_NAME)) {
    r.missing = "storageBuffer8BitAccess (extension VK_KHR_8bit_storage)";
    return r;
  }
  auto s8 =
      make_info<VkPhysicalDevice8BitStorageFeatures>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_8BIT_STORAGE_FEATURES);
  auto s16 = make_info<VkPhysicalDevice16BitStorageFeatures>(
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_16BIT_STORAGE_FEATURES);
  auto f2 = make_info<VkPhysicalDeviceFeatures2>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2);
  s16.pNext = &s8;
  f2.pNext = &s16;
  vkGetPhysicalDeviceFeatures2(d, &f2);
  if (!s8.storageBuffer8BitAccess)
    r.missing = "the feature storageBuffer8BitAccess";
  else if (!s16.storageBuffer16BitAccess)
    r.missing = "the feature storageBuffer16BitAccess";
  else if (!f2.features.shaderInt64)
    r.missing = "the feature shaderInt64";
  return r;
}

DeviceEntry describe(VkPhysicalDevice d, std::uint32_t instance_api) {
  VkPhysicalDeviceProperties props{};
  vkGetPhysicalDeviceProperties(d, &props);
  DeviceEntry e;
  e.name = props.deviceName;
  e.type = type_text(props.deviceType);
  e.api_version = props.apiVersion;
  e.missing = check_requirements(d, instance_api).missing;
  return e;
}

bool all_digits(const std::string& s) {
  return !s.empty() &&
         std::all_of(s.begin(), s.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); });
}

}  // namespace

std::string list_devices(const std::vector<DeviceEntry>& devices) {
  if (devices.empty()) return "none";
  std::ostringstream out;
  for (std::size_t i = 0; i < devices.size(); ++i) {
    out << (i ? "; " : "") << "[" << i << "] " << devices[i].label();
    if (!devices[i].missing.empty()) out << " [unusable: lacks " << devices[i].missing << "]";
  }
  return out.str();
}

DeviceSurvey survey_devices() {
  DeviceSurvey survey;
  try {
    Instance instance = create_instance(false);
    try {
      for (VkPhysicalDevice d : physical_devices(instance.instance))
        survey.devices.push_back(describe(d, instance.api_version));
    } catch (const BackendError& e) {
      survey.error = e.what();
    }
    vkDestroyInstance(instance.instance, nullptr);
  } catch (const BackendError& e) {
    survey.error = e.what();
  }
  return survey;
}

Context::Context(const BackendOptions& options) {
  // Validation: PORTA_VULKAN_VALIDATION=1 requires the layer, 0 turns it off; unset, debug builds
  // use it when it is installed.
  const std::string want_validation = env("PORTA_VULKAN_VALIDATION");
  bool validation = false;
  if (want_validation == "1") {
    if (!layer_installed(kValidationLayer))
      throw BackendError(std::string("vulkan: PORTA_VULKAN_VALIDATION=1 but ") + kValidationLayer +
                         " is not installed (Debian/Ubuntu: apt-get install vulkan-validationlayers)");
    validation = true;
  } else if (want_validation.empty()) {
#ifndef NDEBUG
    validation = layer_installed(kValidationLayer);
#endif
  }
  force_staging_ = env("PORTA_VULKAN_STAGING") == "1";

  const Instance instance = create_instance(validation);
  instance_ = instance.instance;
  try {
    if (validation && instance.debug_utils) {
      auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
          vkGetInstanceProcAddr(instance_, "vkCreateDebugUtilsMessengerEXT"));
      if (create != nullptr) {
        auto info = make_info<VkDebugUtilsMessengerCreateInfoEXT>(
            VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT);
        info.messageSeverity =
            VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
        info.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                           VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                           VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
        info.pfnUserCallback = on_validation_message;
        info.pUserData = this;
        check(create(instance_, &info, nullptr, &messenger_), "vkCreateDebugUtilsMessengerEXT");
      }
    }

    // ---- Device selection ----
    const auto physicals = physical_devices(instance_);
    std::vector<DeviceEntry> entries;
    for (VkPhysicalDevice d : physicals) entries.push_back(describe(d, instance.api_version));
    if (entries.empty())
      throw BackendError(
          "vulkan: no Vulkan device found (the loader found no driver: install one, e.g. "
          "Debian's mesa-vulkan-drivers for lavapipe, or the GPU vendor's driver)");
    std::string want = options.device;
    const char* source = "BackendOptions::device / --device";
    if (want.empty()) {
      want = env("PORTA_VULKAN_DEVICE");
      source = "PORTA_VULKAN_DEVICE";
    }
    std::size_t chosen = entries.size();
    if (want.empty()) {
      int best_rank = 99;
      for (std::size_t i = 0; i < physicals.size(); ++i) {
        if (!entries[i].missing.empty()) continue;
        VkPhysicalDeviceProperties p{};
        vkGetPhysicalDeviceProperties(physicals[i], &p);
        if (type_rank(p.deviceType) < best_rank) {
          best_rank = type_rank(p.deviceType);
          chosen = i;
        }
      }
      if (chosen == entries.size())
        throw BackendError("vulkan: no Vulkan device can run PortaSLAM's kernels; devices found: " +
                           list_devices(entries));
    } else {
      if (all_digits(want)) {  // an index, never a part of a name ("15" of "LLVM 15")
        if (want.size() < 6 && std::stoul(want) < entries.size()) chosen = std::stoul(want);
      } else {
        for (std::size_t i = 0; i < entries.size() && chosen == entries.size(); ++i)
          if (lower(entries[i].name).find(lower(want)) != std::string::npos) chosen = i;
      }
      if (chosen == entries.size())
        throw BackendError(
            "vulkan: no device matches '" + want + "' (from " + source +
            "; an index or a case-insensitive part of the name); devices found: " + list_devices(entries));
      if (!entries[chosen].missing.empty())
        throw BackendError("vulkan: device [" + std::to_string(chosen) + "] " + entries[chosen].label() +
                           " cannot run PortaSLAM's kernels: it lacks " + entries[chosen].missing);
    }
    physical_ = physicals[chosen];
    entry_ = entries[chosen];
    vkGetPhysicalDeviceProperties(physical_, &properties_);
    vkGetPhysicalDeviceMemoryProperties(physical_, &memory_);

    // ---- Logical device ----
    const Requirements req = check_requirements(physical_, instance.api_version);
    queue_family_ = static_cast<std::uint32_t>(compute_family(physical_));
    // kDefaultDeviceQueues queues of that family, or as many as asked for (up to what it has):
    // the runtime's streams are spread over them.
    std::uint32_t families = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(physical_, &families, nullptr);
    std::vector<VkQueueFamilyProperties> family_props(families);
    vkGetPhysicalDeviceQueueFamilyProperties(physical_, &families, family_props.data());
    std::uint32_t queue_count = kDefaultDeviceQueues;
    if (const char* env = std::getenv("PORTA_VULKAN_DEVICE_QUEUES"); env != nullptr && *env != '\0') {
      char* end = nullptr;
      const long n = std::strtol(env, &end, 10);
      if (end == env || *end != '\0' || n < 1 || n > static_cast<long>(kMaxDeviceQueues))
        throw BackendError("vulkan: PORTA_VULKAN_DEVICE_QUEUES must be a count from 1 to " +
                           std::to_string(kMaxDeviceQueues) + ", got '" + env + "'");
      queue_count = static_cast<std::uint32_t>(n);
    }
    queue_count = std::clamp<std::uint32_t>(queue_count, 1, std::max(family_props[queue_family_].queueCount, 1u));
    const std::vector<float> priorities(queue_count, 1.0f);
    VkDeviceQueueCreateInfo queue_infos[2];
    queue_infos[0] = make_info<VkDeviceQueueCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO);
    queue_infos[0].queueFamilyIndex = queue_family_;
    queue_infos[0].queueCount = queue_count;
    queue_infos[0].pQueuePriorities = priorities.data();
    // Uploads on the copy engines, beside the kernels (Context::transfer_queue()), by default where
    // the device has them: with frames in flight on an H100 they took 4-23 % off vulkan's frame
    // (docs/BENCHMARKS.md); elsewhere only when asked for (lavapipe: the tests' path).
    const int copy_family = transfer_only_family(physical_);
    const bool transfer_queue = checks::env_switch("vulkan", "PORTA_VULKAN_TRANSFER_QUEUE", copy_family >= 0);
    std::uint32_t queue_families = 1;
    if (transfer_queue && copy_family >= 0) {
      transfer_family_ = static_cast<std::uint32_t>(copy_family);
      queue_infos[1] = make_info<VkDeviceQueueCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO);
      queue_infos[1].queueFamilyIndex = transfer_family_;
      queue_infos[1].queueCount = 1;
      queue_infos[1].pQueuePriorities = priorities.data();
      queue_families = 2;
    } else {
      transfer_family_ = queue_family_;
    }

    auto s8 = make_info<VkPhysicalDevice8BitStorageFeatures>(
        VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_8BIT_STORAGE_FEATURES);
    s8.storageBuffer8BitAccess = VK_TRUE;
    auto s16 = make_info<VkPhysicalDevice16BitStorageFeatures>(
        VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_16BIT_STORAGE_FEATURES);
    s16.storageBuffer16BitAccess = VK_TRUE;
    s16.pNext = &s8;
    auto features = make_info<VkPhysicalDeviceFeatures2>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2);
    features.features.shaderInt64 = VK_TRUE;
    features.pNext = &s16;

    std::vector<const char*> extensions;
    if (req.needs_8bit_extension) extensions.push_back(VK_KHR_8BIT_STORAGE_EXTENSION_NAME);
    if (req.has_portability_subset) extensions.push_back("VK_KHR_portability_subset");

    auto info = make_info<VkDeviceCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO);
    info.pNext = &features;
    info.queueCreateInfoCount = queue_families;
    info.pQueueCreateInfos = queue_infos;
    info.enabledExtensionCount = static_cast<std::uint32_t>(extensions.size());
    info.ppEnabledExtensionNames = extensions.data();
    check(vkCreateDevice(physical_, &info, nullptr, &device_), "vkCreateDevice", entry_.label());
    queues_.resize(queue_count);
    for (std::uint32_t i = 0; i < queue_count; ++i) vkGetDeviceQueue(device_, queue_family_, i, &queues_[i]);
    if (queue_families == 2) {
      vkGetDeviceQueue(device_, transfer_family_, 0, &transfer_queue_);
    } else if (transfer_queue) {
      transfer_queue_ = queues_[0];
    }
    throw_validation_errors("device creation");
  } catch (...) {
    if (device_ != VK_NULL_HANDLE) vkDestroyDevice(device_, nullptr);
    if (messenger_ != VK_NULL_HANDLE) {
      auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
          vkGetInstanceProcAddr(instance_, "vkDestroyDebugUtilsMessengerEXT"));
      if (destroy != nullptr) destroy(instance_, messenger_, nullptr);
    }
    vkDestroyInstance(instance_, nullptr);
    throw;
  }
}

Context::~Context() {
  if (device_ != VK_NULL_HANDLE) {
    vkDeviceWaitIdle(device_);
    vkDestroyDevice(device_, nullptr);
  }
  if (messenger_ != VK_NULL_HANDLE) {
    auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(instance_, "vkDestroyDebugUtilsMessengerEXT"));
    if (destroy != nullptr) destroy(instance_, messenger_, nullptr);
  }
  if (instance_ != VK_NULL_HANDLE) vkDestroyInstance(instance_, nullptr);
}

MemoryChoice Context::device_memory(std::uint32_t allowed) const {
  constexpr VkMemoryPropertyFlags kUnified =
      VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT | VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT |
      VK_MEMORY_PROPERTY_HOST_COHERENT_BIT | VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
  auto find = [&](VkMemoryPropertyFlags want) -> int {
    for (std::uint32_t i = 0; i < memory_.memoryTypeCount; ++i)
      if ((allowed & (1u << i)) != 0 && (memory_.memoryTypes[i].propertyFlags & want) == want)
        return static_cast<int>(i);
    return -1;
  };
  if (!force_staging_) {
    if (const int t = find(kUnified); t >= 0) return {static_cast<std::uint32_t>(t), true};
  }
  if (const int t = find(VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT); t >= 0)
    return {static_cast<std::uint32_t>(t), false};
  if (const int t = find(0); t >= 0) return {static_cast<std::uint32_t>(t), false};
  throw BackendError("vulkan: no memory type can hold a storage buffer on " + entry_.label());
}

MemoryChoice Context::host_memory(std::uint32_t allowed) const {
  constexpr VkMemoryPropertyFlags kHost =
      VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
  for (const VkMemoryPropertyFlags want : {kHost | VK_MEMORY_PROPERTY_HOST_CACHED_BIT, kHost})
    for (std::uint32_t i = 0; i < memory_.memoryTypeCount; ++i)
      if ((allowed & (1u << i)) != 0 && (memory_.memoryTypes[i].propertyFlags & want) == want)
        return {i, true};
  throw BackendError("vulkan: no host-visible coherent memory type for staging on " + entry_.label());
}

MemoryChoice Context::params_memory(std::uint32_t allowed) const {
  constexpr VkMemoryPropertyFlags kBar =
      VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT | VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
  const char* env = std::getenv("PORTA_VULKAN_PARAMS_MEMORY");
  const std::string where = env != nullptr ? env : "";
  if (!where.empty() && where != "host" && where != "device")
    throw BackendError("vulkan: PORTA_VULKAN_PARAMS_MEMORY must be host or device, got '" + where + "'");
  if (where != "host")
    for (std::uint32_t i = 0; i < memory_.memoryTypeCount; ++i)
      if ((allowed & (1u << i)) != 0 && (memory_.memoryTypes[i].propertyFlags & kBar) == kBar) return {i, true};
  return host_memory(allowed);
}

void Context::add_validation_message(bool is_error, const std::string& text) {
  if (is_error)
    validation_errors_.push_back(text);
  else
    std::cerr << "vulkan validation warning: " << text << "\n";
}

void Context::throw_validation_errors(const char* when) {
  if (validation_errors_.empty()) return;
  std::string message = std::string("vulkan: the validation layer reported ") +
                        std::to_string(validation_errors_.size()) + " error(s) during " + when + ":";
  for (const auto& e : validation_errors_) message += "\n  " + e;
  validation_errors_.clear();
  throw BackendError(message);
}

}  // namespace porta::vulkan
