// Vulkan result codes in words, and the check every Vulkan call of the backend goes through
// (STYLE.md item 8): "vulkan: vkCreateComputePipelines(fast_crf) failed: VK_ERROR_OUT_OF_DEVICE_MEMORY
// (a device memory allocation has failed)".
#pragma once

#include <vulkan/vulkan.h>

#include <string>

namespace porta::vulkan {

/// "VK_ERROR_OUT_OF_DEVICE_MEMORY" for -2, "VkResult(-1234)" for codes it does not know.
std::string result_name(VkResult result);
/// What the code means, in a few words ("" when unknown).
std::string result_meaning(VkResult result);

/// Throws BackendError "vulkan: <call>(<object>) failed: <NAME> (<meaning>)" unless `result` is
/// VK_SUCCESS. `object` names what the call was for (a kernel, a buffer size); may be empty.
void check(VkResult result, const char* call, const std::string& object = {});

}  // namespace porta::vulkan
