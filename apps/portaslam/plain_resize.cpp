#include "plain_resize.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace porta::app {

namespace {

std::uint8_t saturate_round(float v) {  // cv::saturate_cast<uchar>(float): nearest, ties to even
  return static_cast<std::uint8_t>(std::clamp(std::lrint(v), 0L, 255L));
}

// ---- INTER_AREA ------------------------------------------------------------------------------------

// One source pixel's share of one destination pixel (OpenCV's DecimateAlpha).
struct AreaTap {
  int dst;
  int src;
  float alpha;
};

// OpenCV's computeResizeAreaTab: the taps of every destination pixel, in order.
std::vector<AreaTap> area_taps(int src_size, int dst_size, double scale) {
  std::vector<AreaTap> taps;
  for (int d = 0; d < dst_size; ++d) {
    const double f1 = d * scale, f2 = f1 + scale;
    const double cell = std::min(scale, src_size - f1);
    int s2 = std::min(static_cast<int>(std::floor(f2)), src_size - 1);
    const int s1 = std::min(static_cast<int>(std::ceil(f1)), s2);
    if (s1 - f1 > 1e-3) taps.push_back({d, s1 - 1, static_cast<float>((s1 - f1) / cell)});
    for (int s = s1; s < s2; ++s) taps.push_back({d, s, static_cast<float>(1.0 / cell)});
    if (f2 - s2 > 1e-3) taps.push_back({d, s2, static_cast<float>(std::min(std::min(f2 - s2, 1.0), cell) / cell)});
  }
  return taps;
}

// OpenCV's ResizeArea_Invoker for one channel: float sums in the same order.
Image area_general(const ImageView& src, int width, int height, double scale_x, double scale_y) {
  const std::vector<AreaTap> xtab = area_taps(src.width, width, scale_x);
  const std::vector<AreaTap> ytab = area_taps(src.height, height, scale_y);
  Image out(width, height);
  std::vector<float> buf(static_cast<std::size_t>(width)), sum(static_cast<std::size_t>(width), 0.0f);
  int prev = ytab.front().dst;
  auto flush = [&](int row) {
    for (int x = 0; x < width; ++x) out.at(x, row) = saturate_round(sum[static_cast<std::size_t>(x)]);
  };
  for (const AreaTap& ty : ytab) {
    const std::uint8_t* s = src.row(ty.src);
    std::fill(buf.begin(), buf.end(), 0.0f);
    for (const AreaTap& tx : xtab) buf[static_cast<std::size_t>(tx.dst)] += static_cast<float>(s[tx.src]) * tx.alpha;
    if (ty.dst != prev) {
      flush(prev);
      for (int x = 0; x < width; ++x) sum[static_cast<std::size_t>(x)] = ty.alpha * buf[static_cast<std::size_t>(x)];
      prev = ty.dst;
    } else {
      for (int x = 0; x < width; ++x) sum[static_cast<std::size_t>(x)] += ty.alpha * buf[static_cast<std::size_t>(x)];
    }
  }
  flush(prev);
  return out;
}

// OpenCV's resizeAreaFast_: whole blocks of an integer factor; 2x2 rounds half up (its SIMD code),
// other factors multiply by 1 / area in float and round ties to even.
Image area_integer(const ImageView& src, int width, int height, int fx, int fy) {
  Image out(width, height);
  const float inv_area = 1.0f / static_cast<float>(fx * fy);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      int sum = 0;
      for (int k = 0; k < fy; ++k)
        for (int l = 0; l < fx; ++l) sum += src.at(x * fx + l, y * fy + k);
      out.at(x, y) = fx == 2 && fy == 2 ? static_cast<std::uint8_t>((sum + 2) >> 2)
                                        : saturate_round(static_cast<float>(sum) * inv_area);
    }
  return out;
}

// ---- INTER_LINEAR ----------------------------------------------------------------------------------

constexpr int kCoefBits = 11;  // INTER_RESIZE_COEF_BITS
constexpr int kCoefOne = 1 << kCoefBits;

// One destination coordinate: the first source index and the two 11-bit weights.
struct LinearTap {
  int src;
  int w0, w1;
};

// OpenCV clamps a column outside the image to the edge with weight 1, but keeps a row's weights
// and only clamps the row index when reading (`clamp_weights` false), which rounds differently.
LinearTap linear_tap(int d, double scale, int src_size, bool clamp_weights) {
  float f = static_cast<float>((d + 0.5) * scale - 0.5);
  int s = static_cast<int>(std::floor(f));
  f -= static_cast<float>(s);
  if (clamp_weights && s < 0) f = 0.0f, s = 0;
  if (clamp_weights && s >= src_size - 1) f = 0.0f, s = src_size - 1;
  return {s, static_cast<int>(std::lrint((1.0f - f) * kCoefOne)), static_cast<int>(std::lrint(f * kCoefOne))};
}

}  // namespace

Image resize_area(const ImageView& src, int width, int height) {
  const double scale_x = 1.0 / (static_cast<double>(width) / src.width);
  const double scale_y = 1.0 / (static_cast<double>(height) / src.height);
  const int ix = static_cast<int>(std::lround(scale_x)), iy = static_cast<int>(std::lround(scale_y));
  constexpr double eps = std::numeric_limits<double>::epsilon();  // OpenCV's is_area_fast test
  const bool integer = std::abs(scale_x - ix) < eps && std::abs(scale_y - iy) < eps && width * ix <= src.width &&
                       height * iy <= src.height;
  return integer ? area_integer(src, width, height, ix, iy) : area_general(src, width, height, scale_x, scale_y);
}

Image resize_bilinear(const ImageView& src, int width, int height) {
  const double scale_x = 1.0 / (static_cast<double>(width) / src.width);
  const double scale_y = 1.0 / (static_cast<double>(height) / src.height);
  std::vector<LinearTap> xtab;
  for (int x = 0; x < width; ++x) xtab.push_back(linear_tap(x, scale_x, src.width, true));
  // Horizontal pass of every source row a destination row needs, in 11-bit fixed point.
  auto horizontal = [&](int row, std::vector<int>& h) {
    const std::uint8_t* s = src.row(std::clamp(row, 0, src.height - 1));
    for (int x = 0; x < width; ++x) {
      const LinearTap& t = xtab[static_cast<std::size_t>(x)];
      h[static_cast<std::size_t>(x)] = t.src + 1 < src.width ? s[t.src] * t.w0 + s[t.src + 1] * t.w1 : s[t.src] * kCoefOne;
    }
  };
  Image out(width, height);
  std::vector<int> h0(static_cast<std::size_t>(width)), h1(static_cast<std::size_t>(width));
  for (int y = 0; y < height; ++y) {
    const LinearTap t = linear_tap(y, scale_y, src.height, false);
    horizontal(t.src, h0);
    horizontal(t.src + 1, h1);
    for (int x = 0; x < width; ++x) {  // OpenCV's VResizeLinear<uchar, ...> rounding
      const int a = (t.w0 * (h0[static_cast<std::size_t>(x)] >> 4)) >> 16;
      const int b = (t.w1 * (h1[static_cast<std::size_t>(x)] >> 4)) >> 16;
      out.at(x, y) = static_cast<std::uint8_t>((a + b + 2) >> 2);
    }
  }
  return out;
}

}  // namespace porta::app
