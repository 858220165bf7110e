// Byte-exact little-endian encoding for map files (map_file.hpp): fixed-width integers byte by
// byte, floats and doubles as their IEEE bit patterns, so the bytes do not depend on the host and a
// value read back is bit-identical. The reader never reads past its span and checks every count
// against the bytes left before the caller allocates for it.
#pragma once

#include <bit>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#include "porta/slam/map_file.hpp"

namespace porta::slam::map_file {

/// Throws MapFileError("map file 'PATH': PROBLEM").
[[noreturn]] inline void fail(const std::string& path, const std::string& problem) {
  throw MapFileError("map file '" + path + "': " + problem);
}

class ByteWriter {
 public:
  std::vector<std::uint8_t> bytes;

  void u8(std::uint8_t v) { bytes.push_back(v); }
  void u32(std::uint32_t v) { little_endian(v, 4); }
  void u64(std::uint64_t v) { little_endian(v, 8); }
  void i32(std::int32_t v) { u32(static_cast<std::uint32_t>(v)); }
  void f32(float v) { u32(std::bit_cast<std::uint32_t>(v)); }
  void f64(double v) { u64(std::bit_cast<std::uint64_t>(v)); }
  void raw(const void* data, std::size_t n) {
    const auto* p = static_cast<const std::uint8_t*>(data);
    bytes.insert(bytes.end(), p, p + n);
  }
  /// Overwrites 8 bytes at `at` (a section's size, known once its payload is written).
  void patch_u64(std::size_t at, std::uint64_t v) {
    for (int k = 0; k < 8; ++k)
      bytes[at + static_cast<std::size_t>(k)] = static_cast<std::uint8_t>(v >> (8 * k));
  }

 private:
  void little_endian(std::uint64_t v, int n) {
    for (int k = 0; k < n; ++k) bytes.push_back(static_cast<std::uint8_t>(v >> (8 * k)));
  }
};

/// Reads one section's payload. Errors name the file, the section and the file offset.
class ByteReader {
 public:
  ByteReader(std::span<const std::uint8_t> data, const std::string& path, const std::string& section,
             std::uint64_t file_offset)
      : data_(data), path_(path), section_(section), file_offset_(file_offset) {}

  std::size_t left() const { return data_.size() - pos_; }
  std::uint64_t file_offset() const { return file_offset_ + pos_; }

  std::uint8_t u8() { return take(1)[0]; }
  std::uint32_t u32() { return static_cast<std::uint32_t>(little_endian(4)); }
  std::uint64_t u64() { return little_endian(8); }
  std::int32_t i32() { return static_cast<std::int32_t>(u32()); }
  float f32() { return std::bit_cast<float>(u32()); }
  double f64() { return std::bit_cast<double>(u64()); }
  void raw(void* out, std::size_t n) { std::memcpy(out, take(n).data(), n); }

  /// A uint64 count of records of at least `min_record_bytes` each, refused when the rest of the
  /// section could not hold them: a corrupt count never reaches an allocation.
  std::size_t count(std::size_t min_record_bytes, const std::string& what) {
    const std::uint64_t at = file_offset();
    const std::uint64_t n = u64();
    if (n > left() / min_record_bytes) {
      problem("a count of " + std::to_string(n) + " " + what + " at offset " + std::to_string(at) +
              " needs at least " + std::to_string(min_record_bytes) + " bytes each, but only " +
              std::to_string(left()) + " bytes are left in the section");
    }
    return static_cast<std::size_t>(n);
  }

  /// The section must be used up: its size and its content agree.
  void expect_end() const {
    if (left() != 0) {
      problem(std::to_string(left()) + " bytes are left over after its content at offset " +
              std::to_string(file_offset()) + " (the sizes disagree)");
    }
  }

  [[noreturn]] void problem(const std::string& what) const {
    fail(path_, "section '" + section_ + "': " + what);
  }

 private:
  std::span<const std::uint8_t> take(std::size_t n) {
    if (n > left()) {
      problem("its content runs past its end at offset " + std::to_string(file_offset()) + " (needs " +
              std::to_string(n) + " bytes, " + std::to_string(left()) + " left)");
    }
    const auto out = data_.subspan(pos_, n);
    pos_ += n;
    return out;
  }
  std::uint64_t little_endian(int n) {
    const auto b = take(static_cast<std::size_t>(n));
    std::uint64_t v = 0;
    for (int k = 0; k < n; ++k) v |= static_cast<std::uint64_t>(b[static_cast<std::size_t>(k)]) << (8 * k);
    return v;
  }

  std::span<const std::uint8_t> data_;
  std::size_t pos_ = 0;
  std::string path_;
  std::string section_;
  std::uint64_t file_offset_;
};

}  // namespace porta::slam::map_file
