// Synchronized shared memory (DESIGN.md §4): a host copy and a device copy of the same array of
// T, with a record of which side is newer. Access from one side copies from the other only when
// that side is newer. Capacity grows and never shrinks, so per-frame variable counts cause no
// per-frame allocation.
#pragma once

#include <cstddef>
#include <memory>
#include <type_traits>
#include <vector>

#include "porta/backend.hpp"

namespace porta {

template <typename T>
class SyncBuffer {
  static_assert(std::is_trivially_copyable_v<T>);

 public:
  explicit SyncBuffer(Backend& backend) : backend_(&backend) {}

  /// Number of elements in use.
  std::size_t size() const { return size_; }
  std::size_t capacity() const { return capacity_; }
  std::size_t allocations() const { return allocations_; }

  /// Sets the size; grows the storage (keeping the newer side's contents) when needed.
  void resize(std::size_t n) {
    if (n > capacity_) grow(n);
    size_ = n;
  }

  /// Host side for writing: the host copy becomes the newer one.
  T* host_write() {
    pull();
    state_ = State::kHostNewer;
    return host_.data();
  }
  /// Host side for reading: downloads first when the device copy is newer.
  const T* host_read() {
    pull();
    return host_.data();
  }
  /// Device side for reading: uploads first when the host copy is newer.
  const Buffer& device_read() {
    push();
    return *device_;
  }
  /// Device side for writing: uploads first when the host copy is newer (a kernel may read what
  /// it writes), then records the device copy as the newer one.
  Buffer& device_write() {
    push();
    state_ = State::kDeviceNewer;
    return *device_;
  }

 private:
  enum class State { kInSync, kHostNewer, kDeviceNewer };

  void grow(std::size_t n) {
    std::size_t cap = capacity_ == 0 ? n : capacity_;
    while (cap < n) cap *= 2;
    pull();  // keep the contents: the host copy is the one resized
    host_.resize(cap);
    device_ = backend_->allocate(cap * sizeof(T));
    ++allocations_;
    capacity_ = cap;
    state_ = State::kHostNewer;
  }
  void pull() {
    if (state_ == State::kDeviceNewer && size_ > 0) backend_->download(*device_, 0, host_.data(), size_ * sizeof(T));
    if (state_ == State::kDeviceNewer) state_ = State::kInSync;
  }
  void push() {
    if (!device_) grow(1);
    if (state_ == State::kHostNewer && size_ > 0) backend_->upload(*device_, 0, host_.data(), size_ * sizeof(T));
    if (state_ == State::kHostNewer) state_ = State::kInSync;
  }

  Backend* backend_;
  std::vector<T> host_;
  std::unique_ptr<Buffer> device_;
  std::size_t size_ = 0;
  std::size_t capacity_ = 0;
  std::size_t allocations_ = 0;
  State state_ = State::kInSync;
};

}  // namespace porta
