#include "cuda/cuda_errors.hpp"

#include "porta/backend.hpp"

namespace porta::cuda {

std::string error_text(cudaError_t code) {
  const char* name = cudaGetErrorName(code);
  const char* meaning = cudaGetErrorString(code);
  std::string text = name ? name : ("cudaError(" + std::to_string(static_cast<int>(code)) + ")");
  if (meaning) text += std::string(" (") + meaning + ")";
  return text;
}

void check(cudaError_t code, const std::string& call, const std::string& what) {
  if (code == cudaSuccess) return;
  // Clears the runtime's last-error slot, so that a later, unrelated check does not report this
  // error again (sticky errors, such as a kernel fault, stay and are reported by every call).
  static_cast<void>(cudaGetLastError());
  std::string message = "cuda: " + call + " failed: " + error_text(code);
  if (!what.empty()) message += ": " + what;
  throw BackendError(message);
}

}  // namespace porta::cuda
