#include "cpu/cpu_backend.hpp"

#include <cstring>
#include <algorithm>
#include <string>
#include <thread>

#include "porta/registry.hpp"

namespace porta::cpu {

CpuBuffer::CpuBuffer(std::size_t bytes) : Buffer(bytes), bytes_(new std::uint8_t[bytes > 0 ? bytes : 1]()) {}

CpuBackend::CpuBackend(int threads) : pool_(threads, "porta-cpu") {}

std::string CpuBackend::device_name() const { return "cpu (" + std::to_string(pool_.size()) + " threads)"; }

std::unique_ptr<Buffer> CpuBackend::allocate(std::size_t bytes) { return std::make_unique<CpuBuffer>(bytes); }

namespace {
void check_range(const Buffer& b, std::size_t offset, std::size_t bytes, const char* call) {
  if (offset > b.size_bytes() || bytes > b.size_bytes() - offset)
    throw BackendError(std::string("cpu: ") + call + ": range [" + std::to_string(offset) + ", +" +
                       std::to_string(bytes) + ") is outside the buffer of " + std::to_string(b.size_bytes()) +
                       " bytes");
}
}  // namespace

void CpuBackend::upload(Buffer& dst, std::size_t dst_offset, const void* src, std::size_t bytes) {
  check_range(dst, dst_offset, bytes, "upload");
  if (bytes) std::memcpy(as<std::uint8_t>(dst, static_cast<std::int64_t>(dst_offset)), src, bytes);
}

void CpuBackend::download(const Buffer& src, std::size_t src_offset, void* dst, std::size_t bytes) {
  check_range(src, src_offset, bytes, "download");
  if (bytes) std::memcpy(dst, as<std::uint8_t>(src, static_cast<std::int64_t>(src_offset)), bytes);
}

void CpuBackend::fill(Buffer& dst, std::size_t offset, std::size_t bytes, std::uint8_t value) {
  check_range(dst, offset, bytes, "fill");
  if (bytes) std::memset(as<std::uint8_t>(dst, static_cast<std::int64_t>(offset)), value, bytes);
}

}  // namespace porta::cpu

namespace porta {

void register_cpu_backend(BackendRegistry& registry) {
  registry.add(
      "cpu",
      [] {
        BackendInfo info;
        info.name = "cpu";
        info.compiled = true;
        info.available = true;
        info.detail = "cpu (" + std::to_string(std::max(1u, std::thread::hardware_concurrency())) + " threads)";
        return info;
      },
      [](const BackendOptions& options) -> std::unique_ptr<Backend> {
        return std::make_unique<cpu::CpuBackend>(options.threads);
      });
}

}  // namespace porta
