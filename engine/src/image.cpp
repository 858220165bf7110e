#include "porta/image.hpp"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>

namespace porta {

Image::Image(int width, int height, int pitch_bytes)
    : width_(width), height_(height), pitch_(pitch_bytes == 0 ? width : pitch_bytes) {
  if (width < 0 || height < 0) throw std::invalid_argument("Image: negative size");
  if (pitch_ < width_)
    throw std::invalid_argument("Image: pitch " + std::to_string(pitch_) + " is smaller than width " +
                                std::to_string(width_));
  pixels_.assign(static_cast<std::size_t>(pitch_) * static_cast<std::size_t>(height_), 0);
}

Image Image::copy_of(const ImageView& view, int pitch_bytes) {
  Image out(view.width, view.height, pitch_bytes);
  for (int y = 0; y < view.height; ++y) std::memcpy(out.row(y), view.row(y), static_cast<std::size_t>(view.width));
  return out;
}

}  // namespace porta
