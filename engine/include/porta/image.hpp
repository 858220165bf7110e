// Host images: 8-bit grayscale with an explicit row pitch (DESIGN.md §3).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace porta {

/// A non-owning view of an 8-bit grayscale image. `pitch_bytes` >= `width`.
struct ImageView {
  const std::uint8_t* data = nullptr;
  int width = 0;
  int height = 0;
  int pitch_bytes = 0;

  const std::uint8_t* row(int y) const { return data + static_cast<std::ptrdiff_t>(y) * pitch_bytes; }
  std::uint8_t at(int x, int y) const { return row(y)[x]; }
  bool empty() const { return width <= 0 || height <= 0 || data == nullptr; }
};

/// An owning 8-bit grayscale image. Rows are `pitch_bytes` apart; padding bytes are zero.
class Image {
 public:
  Image() = default;
  /// A zero-filled image; `pitch_bytes` 0 means tightly packed (pitch = width).
  Image(int width, int height, int pitch_bytes = 0);

  int width() const { return width_; }
  int height() const { return height_; }
  int pitch_bytes() const { return pitch_; }
  bool empty() const { return width_ <= 0 || height_ <= 0; }

  std::uint8_t* row(int y) { return pixels_.data() + static_cast<std::ptrdiff_t>(y) * pitch_; }
  const std::uint8_t* row(int y) const { return pixels_.data() + static_cast<std::ptrdiff_t>(y) * pitch_; }
  std::uint8_t& at(int x, int y) { return row(y)[x]; }
  std::uint8_t at(int x, int y) const { return row(y)[x]; }
  std::uint8_t* data() { return pixels_.data(); }
  const std::uint8_t* data() const { return pixels_.data(); }
  std::size_t size_bytes() const { return pixels_.size(); }

  ImageView view() const { return {pixels_.data(), width_, height_, pitch_}; }
  /// Copies a view (any pitch) into a new image with the given pitch (0 = packed).
  static Image copy_of(const ImageView& view, int pitch_bytes = 0);

 private:
  int width_ = 0;
  int height_ = 0;
  int pitch_ = 0;
  std::vector<std::uint8_t> pixels_;
};

}  // namespace porta
