// Procedural textures of the renderer: tileable 8-bit images with natural-image statistics
// (multi-octave noise with a roughly 1/f spectrum, blobs, cracks, bricks, tiles, patterns), built
// once per seed with a full mip chain (box-filtered), sampled bilinearly at the mip level that
// matches a sample's footprint, so that minified textures do not alias.
#pragma once

#include <array>
#include <bit>
#include <cstdint>
#include <vector>

namespace porta::slam::render {

/// What a texture looks like. Each has its own generator (texture.cpp).
enum class Material : int {
  asphalt,
  paving,     ///< paving slabs
  brick,
  plaster,
  grass,
  wood,       ///< floor planks
  concrete,
  patterned,  ///< posters, shelves, pictures: rectangles, discs, stripes at many scales
  clouds,     ///< the sky
  count
};
constexpr int kMaterialCount = static_cast<int>(Material::count);

/// A square power-of-two texture and its mip chain; level 0 is `size` x `size` texels.
class MipTexture {
 public:
  MipTexture() = default;
  /// Builds the chain from level 0 (size*size values in [0, 255], size a power of two >= 2).
  MipTexture(int size, const std::vector<float>& level0);

  int size() const { return size_; }
  int levels() const { return static_cast<int>(levels_.size()); }
  /// Bilinear sample at texel coordinates (u, v) of level 0, wrapped, from level `level`.
  float sample(int level, float u, float v) const {
    const int n = size_ >> level, mask = n - 1;
    const float scale = 1.0f / static_cast<float>(1 << level);
    const float x = u * scale - 0.5f, y = v * scale - 0.5f;
    int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
    x0 -= x < static_cast<float>(x0);  // floor
    y0 -= y < static_cast<float>(y0);
    const float fx = x - static_cast<float>(x0), fy = y - static_cast<float>(y0);
    const std::uint8_t* t = levels_[static_cast<std::size_t>(level)].data();
    const int xa = x0 & mask, xb = (x0 + 1) & mask, ya = (y0 & mask) * n, yb = ((y0 + 1) & mask) * n;
    const float top = t[ya + xa] + fx * (static_cast<float>(t[ya + xb]) - t[ya + xa]);
    const float bottom = t[yb + xa] + fx * (static_cast<float>(t[yb + xb]) - t[yb + xa]);
    return top + fy * (bottom - top);
  }
  /// Mean value of the whole texture (the top of the chain).
  float mean() const { return levels_.back()[0]; }

 private:
  int size_ = 0;
  int log2_size_ = 0;
  std::vector<std::vector<std::uint8_t>> levels_;
};

/// Mip level for a sample whose footprint spans `texels` level-0 texels (floor of log2, clamped).
inline int mip_level_for(float texels, int levels) {
  if (!(texels > 1.0f)) return 0;
  const int level = static_cast<int>((std::bit_cast<std::uint32_t>(texels) >> 23) & 0xFFu) - 127;  // floor(log2)
  return level < levels - 1 ? level : levels - 1;
}

/// One texture per material, generated from a seed (in parallel over `threads`; the result does
/// not depend on the thread count).
class TextureBank {
 public:
  TextureBank(std::uint64_t seed, int size = 512, int threads = 1);
  const MipTexture& get(Material m) const { return textures_[static_cast<int>(m)]; }
  int size() const { return size_; }

 private:
  int size_;
  std::array<MipTexture, kMaterialCount> textures_;
};

/// Generates level 0 of a material's texture (size x size values in [0, 255]). Exposed for tests.
std::vector<float> generate_texture(Material material, int size, std::uint64_t seed);

}  // namespace porta::slam::render
