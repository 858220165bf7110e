// Equivalence of the image kernels (DESIGN.md §3.1, §3.2, §3.7): rectify, build_pyramid, blur.
// Outputs start poisoned, so a pixel a backend leaves unwritten differs from cpu; only pixels
// inside each plane's width x height are compared.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>
#include <sstream>
#include <string>

#include "equivalence/compare.hpp"
#include "equivalence/harness.hpp"
#include "equivalence/inputs.hpp"

namespace porta::eq {
namespace {

std::size_t middle_offset(const Plane& p, int element_bytes) {
  return static_cast<std::size_t>(
      p.offset_bytes + (static_cast<std::int64_t>(p.height / 2) * p.pitch + p.width / 2) * element_bytes);
}

// ---- rectify -------------------------------------------------------------------------------------

/// A remap of a source plane into a destination plane through a synthetic camera model (rotation,
/// radial distortion, zoom, shift), computed in double and rounded to Q5 as the contract says.
struct RectifyInput {
  Plane src, dst;
  std::vector<std::uint8_t> src_bytes;  ///< the whole source buffer (padding holds a pattern)
  std::vector<std::int32_t> map;        ///< dst.width * dst.height (x, y) pairs, Q5
  std::string description;
};

RectifyInput make_rectify_input(const Image& image, int variant) {
  struct Model {
    double k1, k2, angle_deg, zoom, shift_x, shift_y, dst_w, dst_h;
  };
  static const Model models[] = {
      {-0.25, 0.05, 2.0, 1.0, 0.0, 0.0, 1.0, 1.0},      // barrel: corners pulled in
      {0.18, 0.0, -4.0, 1.15, 1.5, -2.25, 0.75, 1.25},  // pincushion into a resized destination
      {0.0, 0.0, 30.0, 0.8, 0.3, -0.2, 1.0, 1.0},       // strong rotation: many taps off the image
  };
  const Model& m = models[variant % 3];
  RectifyInput in;
  const int w = image.width(), h = image.height();
  in.src = Plane{256, w, h, image.pitch_bytes()};
  in.src_bytes.assign(static_cast<std::size_t>(256 + static_cast<std::int64_t>(in.src.pitch) * h), 0x5A);
  for (int y = 0; y < h; ++y)
    std::memcpy(
        in.src_bytes.data() + 256 + static_cast<std::size_t>(y) * static_cast<std::size_t>(in.src.pitch),
        image.row(y), static_cast<std::size_t>(w));
  const int dw = std::max(1, static_cast<int>(std::lround(w * m.dst_w)));
  const int dh = std::max(1, static_cast<int>(std::lround(h * m.dst_h)));
  in.dst = Plane{128, dw, dh, dw + 7};

  std::ostringstream d;
  d << "map: radial k1 " << m.k1 << ", k2 " << m.k2 << ", rotation " << m.angle_deg << " deg, zoom " << m.zoom
    << ", shift (" << m.shift_x << ", " << m.shift_y << ") of the size; source at byte 256 with pitch "
    << in.src.pitch << "; destination " << dw << "x" << dh << " at byte 128 with pitch " << in.dst.pitch;
  in.description = d.str();
  const double angle = m.angle_deg * std::numbers::pi / 180.0;
  const double fd = std::max(dw, dh) / 2.0, fs = std::max(w, h) / 2.0;
  in.map.resize(static_cast<std::size_t>(dw) * static_cast<std::size_t>(dh) * 2);
  for (int y = 0; y < dh; ++y)
    for (int x = 0; x < dw; ++x) {
      const double u = (x - (dw - 1) / 2.0) / fd, v = (y - (dh - 1) / 2.0) / fd;
      const double ur = std::cos(angle) * u - std::sin(angle) * v;
      const double vr = std::sin(angle) * u + std::cos(angle) * v;
      const double r2 = ur * ur + vr * vr;
      const double s = 1.0 + m.k1 * r2 + m.k2 * r2 * r2;
      const double sx = (w - 1) / 2.0 + ur * s * fs * m.zoom + m.shift_x * w;
      const double sy = (h - 1) / 2.0 + vr * s * fs * m.zoom + m.shift_y * h;
      const std::size_t at =
          (static_cast<std::size_t>(y) * static_cast<std::size_t>(dw) + static_cast<std::size_t>(x)) * 2;
      in.map[at] = static_cast<std::int32_t>(std::llround(sx * 32.0));
      in.map[at + 1] = static_cast<std::int32_t>(std::llround(sy * 32.0));
    }
  return in;
}

class Rectify : public KernelEquivalence {};

TEST_P(Rectify, MatchesCpu) {
  std::string why;
  const Image* image = input_image(GetParam().inputs[0], why);
  if (image == nullptr) {
    note_input_skip();
    GTEST_SKIP() << why;
  }
  const RectifyInput in = make_rectify_input(*image, GetParam().variant);
  const auto dst_bytes =
      static_cast<std::size_t>(in.dst.offset_bytes + static_cast<std::int64_t>(in.dst.pitch) * in.dst.height);
  auto out = run_both([&](Backend& b) {
    auto src = upload_vector(b, in.src_bytes);
    auto map = upload_vector(b, in.map);
    auto dst = poisoned(b, dst_bytes);
    b.rectify(*src, in.src, *map, *dst, in.dst);
    return download_bytes(b, *dst, dst_bytes);
  });
  if (!out) return;
  debug_corrupt(out->second.data(), out->second.size(), middle_offset(in.dst, 1));
  const Mismatch m =
      compare_planes(out->first, out->second, {in.dst}, 1, {"cpu", backend_name()}, "destination");
  expect_same(m ? Mismatch(in.description + "\n  " + *m) : m);
}

INSTANTIATE_TEST_SUITE_P(Equivalence, Rectify, ::testing::ValuesIn(cases_for("rectify")), case_name);

// ---- build_pyramid -------------------------------------------------------------------------------

class BuildPyramid : public KernelEquivalence {};

TEST_P(BuildPyramid, MatchesCpu) {
  PORTA_EQ_SCENE_OR_SKIP(s, GetParam().inputs[0], GetParam().profile);
  const auto total = static_cast<std::size_t>(s->layout.total_bytes);
  // Level 0 in place; everything else (padding, levels 1..) poisoned.
  std::vector<std::uint8_t> initial(total, kPoison);
  const Plane& l0 = s->layout.levels[0];
  for (int y = 0; y < l0.height; ++y) {
    const auto at = static_cast<std::size_t>(static_cast<std::int64_t>(y) * l0.pitch);
    std::memcpy(initial.data() + at, s->level0.data() + at, static_cast<std::size_t>(l0.width));
  }
  auto out = run_both([&](Backend& b) {
    auto pyramid = upload_vector(b, initial);
    auto resize = upload_vector(b, s->tables.resize.packed);
    b.build_pyramid(*pyramid, s->layout, *resize, s->tables.resize.level_offset);
    return download_bytes(b, *pyramid, total);
  });
  if (!out) return;
  debug_corrupt(out->second.data(), out->second.size(), middle_offset(s->layout.levels.back(), 1));
  expect_same(compare_planes(out->first, out->second, s->layout.levels, 1, {"cpu", backend_name()}));
}

INSTANTIATE_TEST_SUITE_P(Equivalence, BuildPyramid, ::testing::ValuesIn(cases_for("build_pyramid")),
                         case_name);

// ---- blur ----------------------------------------------------------------------------------------

class Blur : public KernelEquivalence {};

TEST_P(Blur, MatchesCpu) {
  PORTA_EQ_SCENE_OR_SKIP(s, GetParam().inputs[0], GetParam().profile);
  const auto total = static_cast<std::size_t>(s->layout.total_bytes);
  auto out = run_both([&](Backend& b) {
    auto pyramid = upload_vector(b, s->pyramid);
    auto blurred = poisoned(b, total);
    b.blur(*pyramid, s->layout, *blurred, s->tables.blur_taps);
    return download_bytes(b, *blurred, total);
  });
  if (!out) return;
  debug_corrupt(out->second.data(), out->second.size(), middle_offset(s->layout.levels[0], 1));
  expect_same(compare_planes(out->first, out->second, s->layout.levels, 1, {"cpu", backend_name()}));
}

INSTANTIATE_TEST_SUITE_P(Equivalence, Blur, ::testing::ValuesIn(cases_for("blur")), case_name);

}  // namespace
}  // namespace porta::eq
