// Little-endian byte packing for the place-recognition database's serialised form (the PLDB section
// of a map file). Private to slam/place/. Reads check every size against the bytes left before
// allocating, so a corrupt count is an error, never a huge allocation.
#pragma once

#include <bit>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include "porta/slam/place_recognition.hpp"

namespace porta::slam::place_bytes {

static_assert(std::endian::native == std::endian::little, "the map format is little-endian");

/// resize + memcpy rather than insert: GCC 12 warns falsely (stringop-overflow) on the insert.
inline void put_bytes(std::vector<std::uint8_t>& out, const void* data, std::size_t n) {
  const std::size_t at = out.size();
  out.resize(at + n);
  std::memcpy(out.data() + at, data, n);
}

template <class T>
void put(std::vector<std::uint8_t>& out, T value) {
  static_assert(std::is_arithmetic_v<T>);
  put_bytes(out, &value, sizeof(T));
}

struct Reader {
  std::span<const std::uint8_t> bytes;
  std::size_t offset = 0;
  const char* what = "";

  [[noreturn]] void fail(const std::string& message) const {
    throw PlaceDatabaseError(std::string("place database: ") + what + " " + message + " (at byte " +
                             std::to_string(offset) + " of " + std::to_string(bytes.size()) + ")");
  }
  void need(std::size_t n) const {
    if (n > bytes.size() - offset) {
      fail("is truncated: " + std::to_string(n) + " more bytes needed, " + std::to_string(bytes.size() - offset) +
           " left");
    }
  }
  template <class T>
  T get() {
    need(sizeof(T));
    T value;
    std::memcpy(&value, bytes.data() + offset, sizeof(T));
    offset += sizeof(T);
    return value;
  }
  void get_bytes(std::uint8_t* out, std::size_t n) {
    need(n);
    std::memcpy(out, bytes.data() + offset, n);
    offset += n;
  }
  /// A uint64 count of items that take at least `min_bytes_each` bytes each.
  std::uint64_t get_count(std::size_t min_bytes_each) {
    const auto count = get<std::uint64_t>();
    if (count > (bytes.size() - offset) / min_bytes_each) {
      fail("claims " + std::to_string(count) + " items, more than the " + std::to_string(bytes.size() - offset) +
           " bytes left can hold");
    }
    return count;
  }
};

}  // namespace porta::slam::place_bytes
