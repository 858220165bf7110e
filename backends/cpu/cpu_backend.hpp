// The cpu backend: the reference implementation of every kernel contract (DESIGN.md §3), plain
// C++ over host memory, multithreaded by rows, levels or keypoints but deterministic.
#pragma once

#include <memory>
#include <string>

#include "cpu/thread_pool.hpp"
#include "porta/backend.hpp"

namespace porta::cpu {

/// Host memory standing in for device memory.
class CpuBuffer final : public Buffer {
 public:
  explicit CpuBuffer(std::size_t bytes);
  std::uint8_t* data() { return bytes_.get(); }
  const std::uint8_t* data() const { return bytes_.get(); }

 private:
  std::unique_ptr<std::uint8_t[]> bytes_;
};

/// The bytes of a buffer made by a CpuBackend, viewed as T.
template <typename T>
T* as(Buffer& b, std::int64_t offset_bytes = 0) {
  return reinterpret_cast<T*>(static_cast<CpuBuffer&>(b).data() + offset_bytes);
}
template <typename T>
const T* as(const Buffer& b, std::int64_t offset_bytes = 0) {
  return reinterpret_cast<const T*>(static_cast<const CpuBuffer&>(b).data() + offset_bytes);
}
/// The number of records of a device list.
inline int list_count(const ConstDeviceList& l) {
  const auto n = static_cast<int>(*as<std::uint32_t>(*l.count, l.count_offset_bytes));
  return n < l.capacity ? n : l.capacity;
}

class CpuBackend final : public Backend {
 public:
  explicit CpuBackend(int threads = 0);

  std::string name() const override { return "cpu"; }
  std::string device_name() const override;
  bool host_visible() const override { return true; }

  std::unique_ptr<Buffer> allocate(std::size_t bytes) override;
  void upload(Buffer& dst, std::size_t dst_offset, const void* src, std::size_t bytes) override;
  void download(const Buffer& src, std::size_t src_offset, void* dst, std::size_t bytes) override;
  void fill(Buffer& dst, std::size_t offset, std::size_t bytes, std::uint8_t value) override;
  void synchronize() override {}

  PORTA_BACKEND_KERNEL_OVERRIDES;

  ThreadPool& pool() { return pool_; }

 private:
  ThreadPool pool_;
};

}  // namespace porta::cpu
