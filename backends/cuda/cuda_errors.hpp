// CUDA runtime errors in words, and the check every CUDA call of the backend goes through.
#pragma once

#include <cuda_runtime_api.h>

#include <string>

namespace porta::cuda {

/// "cudaErrorMemoryAllocation (out of memory)".
std::string error_text(cudaError_t code);

/// Throws BackendError "cuda: <call> failed: <name> (<meaning>)[: <what>]" unless code is
/// cudaSuccess, e.g. "cuda: cudaMalloc(123 bytes) failed: cudaErrorMemoryAllocation (out of memory)".
void check(cudaError_t code, const std::string& call, const std::string& what = {});

}  // namespace porta::cuda
