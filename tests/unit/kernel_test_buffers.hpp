// Small helpers for kernel unit tests: images in and out of the levels of a pyramid buffer,
// host vectors and keypoint lists into device buffers.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "porta/backend.hpp"
#include "porta/image.hpp"
#include "porta/keypoint.hpp"
#include "porta/layout.hpp"

namespace porta::test {

/// A buffer of `layout` whose levels hold `images` (one per level, same sizes; padding zero).
inline std::unique_ptr<Buffer> upload_levels(Backend& backend, const PyramidLayout& layout,
                                             const std::vector<Image>& images) {
  auto buffer = backend.allocate(static_cast<std::size_t>(layout.total_bytes));
  backend.fill(*buffer, 0, buffer->size_bytes(), 0);
  for (std::size_t n = 0; n < images.size(); ++n) {
    const Plane& p = layout.levels[n];
    for (int y = 0; y < images[n].height(); ++y)
      backend.upload(*buffer,
                     static_cast<std::size_t>(p.offset_bytes + static_cast<std::int64_t>(y) * p.pitch),
                     images[n].row(y), static_cast<std::size_t>(images[n].width()));
  }
  return buffer;
}

/// Each level of a pyramid buffer as a packed image.
inline std::vector<Image> download_levels(Backend& backend, const Buffer& buffer,
                                          const PyramidLayout& layout) {
  std::vector<Image> levels;
  for (const Plane& p : layout.levels) {
    Image img(p.width, p.height);
    for (int y = 0; y < p.height; ++y)
      backend.download(buffer,
                       static_cast<std::size_t>(p.offset_bytes + static_cast<std::int64_t>(y) * p.pitch),
                       img.row(y), static_cast<std::size_t>(p.width));
    levels.push_back(std::move(img));
  }
  return levels;
}

template <typename T>
std::unique_ptr<Buffer> upload_vector(Backend& backend, const std::vector<T>& v) {
  auto b = backend.allocate(std::max<std::size_t>(1, v.size() * sizeof(T)));
  if (!v.empty()) backend.upload(*b, 0, v.data(), v.size() * sizeof(T));
  return b;
}

/// A keypoint at (x, y) of `level` with orientation bin `angle_bin` (response 1000: any non-zero).
inline Keypoint keypoint_at(int x, int y, int level = 0, int angle_bin = 0) {
  Keypoint k;
  k.x = static_cast<std::uint16_t>(x);
  k.y = static_cast<std::uint16_t>(y);
  k.response = 1000;
  k.level = static_cast<std::uint8_t>(level);
  k.angle_bin = static_cast<std::uint8_t>(angle_bin);
  return k;
}

/// A keypoint list holding `keypoints` (count at byte 0 of its own buffer).
struct KeypointList {
  std::unique_ptr<Buffer> items;
  std::unique_ptr<Buffer> count;
  DeviceList list;
};

inline KeypointList upload_keypoint_list(Backend& backend, const std::vector<Keypoint>& keypoints) {
  KeypointList k;
  k.items = upload_vector(backend, keypoints);
  const std::vector<std::uint32_t> count = {static_cast<std::uint32_t>(keypoints.size())};
  k.count = upload_vector(backend, count);
  k.list = DeviceList{k.items.get(), k.count.get(), 0, static_cast<int>(keypoints.size())};
  return k;
}

/// Byte-for-byte comparison that names the first differing pixel.
inline void expect_same_image(const Image& actual, const Image& expected, const std::string& what) {
  ASSERT_EQ(actual.width(), expected.width()) << what;
  ASSERT_EQ(actual.height(), expected.height()) << what;
  for (int y = 0; y < expected.height(); ++y)
    for (int x = 0; x < expected.width(); ++x)
      if (actual.at(x, y) != expected.at(x, y))
        FAIL() << what << ": first difference at (" << x << ", " << y << "): got " << int(actual.at(x, y))
               << ", expected " << int(expected.at(x, y));
}

}  // namespace porta::test
