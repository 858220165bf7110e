#include "vulkan/vk_errors.hpp"

#include "porta/backend.hpp"

namespace porta::vulkan {

namespace {
struct ResultText {
  VkResult result;
  const char* name;
  const char* meaning;
};
constexpr ResultText kResults[] = {
    {VK_SUCCESS, "VK_SUCCESS", "success"},
    {VK_NOT_READY, "VK_NOT_READY", "a fence or query has not yet completed"},
    {VK_TIMEOUT, "VK_TIMEOUT", "a wait operation has not completed in the specified time"},
    {VK_INCOMPLETE, "VK_INCOMPLETE", "a return array was too small for the result"},
    {VK_ERROR_OUT_OF_HOST_MEMORY, "VK_ERROR_OUT_OF_HOST_MEMORY", "a host memory allocation has failed"},
    {VK_ERROR_OUT_OF_DEVICE_MEMORY, "VK_ERROR_OUT_OF_DEVICE_MEMORY", "a device memory allocation has failed"},
    {VK_ERROR_INITIALIZATION_FAILED, "VK_ERROR_INITIALIZATION_FAILED",
     "initialization of an object could not be completed"},
    {VK_ERROR_DEVICE_LOST, "VK_ERROR_DEVICE_LOST", "the logical or physical device has been lost"},
    {VK_ERROR_MEMORY_MAP_FAILED, "VK_ERROR_MEMORY_MAP_FAILED", "mapping of a memory object has failed"},
    {VK_ERROR_LAYER_NOT_PRESENT, "VK_ERROR_LAYER_NOT_PRESENT", "a requested layer is not present"},
    {VK_ERROR_EXTENSION_NOT_PRESENT, "VK_ERROR_EXTENSION_NOT_PRESENT",
     "a requested extension is not supported"},
    {VK_ERROR_FEATURE_NOT_PRESENT, "VK_ERROR_FEATURE_NOT_PRESENT", "a requested feature is not supported"},
    {VK_ERROR_INCOMPATIBLE_DRIVER, "VK_ERROR_INCOMPATIBLE_DRIVER",
     "no compatible Vulkan driver (ICD) is installed, or it does not support the requested version"},
    {VK_ERROR_TOO_MANY_OBJECTS, "VK_ERROR_TOO_MANY_OBJECTS",
     "too many objects of the type have been created"},
    {VK_ERROR_FORMAT_NOT_SUPPORTED, "VK_ERROR_FORMAT_NOT_SUPPORTED", "a requested format is not supported"},
    {VK_ERROR_FRAGMENTED_POOL, "VK_ERROR_FRAGMENTED_POOL", "a pool allocation failed due to fragmentation"},
    {VK_ERROR_UNKNOWN, "VK_ERROR_UNKNOWN", "an unknown error has occurred"},
    {VK_ERROR_OUT_OF_POOL_MEMORY, "VK_ERROR_OUT_OF_POOL_MEMORY", "a pool memory allocation has failed"},
    {VK_ERROR_FRAGMENTATION, "VK_ERROR_FRAGMENTATION",
     "a descriptor pool creation failed due to fragmentation"},
    {VK_ERROR_VALIDATION_FAILED_EXT, "VK_ERROR_VALIDATION_FAILED_EXT", "a validation layer found an error"},
    {VK_ERROR_INVALID_SHADER_NV, "VK_ERROR_INVALID_SHADER_NV", "a shader failed to compile or link"},
};
}  // namespace

std::string result_name(VkResult result) {
  for (const auto& r : kResults)
    if (r.result == result) return r.name;
  return "VkResult(" + std::to_string(static_cast<int>(result)) + ")";
}

std::string result_meaning(VkResult result) {
  for (const auto& r : kResults)
    if (r.result == result) return r.meaning;
  return {};
}

void check(VkResult result, const char* call, const std::string& object) {
  if (result == VK_SUCCESS) return;
  std::string message = std::string("vulkan: ") + call;
  if (!object.empty()) message += "(" + object + ")";
  message += " failed: " + result_name(result);
  if (const std::string meaning = result_meaning(result); !meaning.empty()) message += " (" + meaning + ")";
  throw BackendError(message);
}

}  // namespace porta::vulkan
