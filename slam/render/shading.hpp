// Shading (internal to rasterizer.cpp; inline so the per-pixel loop inlines it). Shading runs once
// per output pixel and polygon (the depth pass is supersampled, MSAA-like), so every shading term
// is prefiltered over the pixel's footprint: textures through their mip chain, procedural overlays
// (windows, posters, panels) by analytic box-filter coverage of their edges.
// A surface's texture is two lookups at incommensurate scales and angles, so that a large surface
// never shows a periodic pattern.
#pragma once

#include <algorithm>
#include <cmath>

#include "porta/slam/render/hash.hpp"
#include "porta/slam/render/rasterizer.hpp"

namespace porta::slam::render::detail {

inline float fract_of(float x) { return x - std::floor(x); }

inline std::uint32_t cell_hash(std::uint32_t h, int a, int b) {
  return static_cast<std::uint32_t>(mix64((static_cast<std::uint64_t>(h) << 32) ^
                                          (static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 16) ^
                                          static_cast<std::uint32_t>(b)) >>
                                    40);  // 24 random bits
}

// Fraction of a box filter of width `fw` centred `d` from the centre of the interval |x| < half.
inline float coverage(float d, float half, float fw) {
  return std::clamp(std::min((half - d) / fw + 0.5f, 2.0f * half / fw), 0.0f, 1.0f);
}
// Coverage of a rectangle |du| < hu, |dv| < hv.
inline float box_coverage(float du, float dv, float hu, float hv, float fw) {
  return coverage(du, hu, fw) * coverage(dv, hv, fw);
}

// Window grid on a façade: u along the façade, v up from the lot's ground (m); fw = footprint (m).
inline float windows(const Surface& s, float u, float v, float fw, float wall, float detail) {
  const float spacing = s.overlay_params[0], floor_h = 3.2f;
  const float half_w = 0.5f * s.overlay_params[1] * spacing, half_h = 0.5f * s.overlay_params[2] * floor_h;
  constexpr float frame = 0.09f, ledge = 0.12f;
  const float cu = u / spacing, cv = v / floor_h;
  const int col = static_cast<int>(std::floor(cu)), row = static_cast<int>(std::floor(cv));
  const std::uint32_t h = cell_hash(s.hash, col, row);
  const float frame_value = 175.0f + static_cast<float>(h & 63u);
  float glass = 35.0f + s.overlay_params[3] * 0.5f + static_cast<float>((h >> 6) & 63u) + 0.35f * detail;
  const float average = wall * 0.7f + 0.3f * (0.5f * frame_value + 0.5f * glass);
  if (fw > 0.4f * spacing) return average;  // far away: the grid is below the pixel size
  const float du = std::abs(fract_of(cu) - 0.5f) * spacing;  // metres from the window's centre line
  const float dv_signed = (fract_of(cv) - 0.55f) * floor_h, dv = std::abs(dv_signed);
  if (v < 0.6f) return wall;
  const float outer = box_coverage(du, dv, half_w + frame, half_h + frame, fw);
  // A ledge under each row of windows.
  const float ledge_cover = box_coverage(du, std::abs(dv_signed + half_h + frame + ledge / 2), half_w + 2 * frame, ledge / 2, fw);
  const float wall_value = wall + ledge_cover * (wall * -0.45f + 20.0f);
  if (outer <= 0.0f) return wall_value;
  const float inner = box_coverage(du, dv, half_w, half_h, fw);
  if (((h >> 12) & 3u) == 0) {  // a blind pulled down part way
    const float blind_to = -half_h + 2 * half_h * static_cast<float>((h >> 14) & 7u) / 8.0f;
    const float blind = std::clamp((blind_to - dv_signed) / fw + 0.5f, 0.0f, 1.0f);
    glass += blind * (150.0f + static_cast<float>((h >> 17) & 31u) - glass);
  }
  glass += coverage(du, 0.03f, fw) * (150.0f - glass);  // mullion
  return wall_value * (1.0f - outer) + frame_value * (outer - inner) + glass * inner;
}

// Posters, pictures and notice boards on a room wall in some cells of a grid.
inline float posters(const Surface& s, const TextureBank& textures, float u, float v, float fw, float wall) {
  const float cell = s.overlay_params[0];
  if (v < 0.4f || v > 2.8f) return wall;
  const int cu = static_cast<int>(std::floor(u / cell)), cv = static_cast<int>(std::floor(v / cell));
  const std::uint32_t h = cell_hash(s.hash, cu, cv);
  if (static_cast<float>(h & 255u) / 256.0f > s.overlay_params[1]) return wall;
  const float fu = fract_of(u / cell) * cell, fv = fract_of(v / cell) * cell;
  const float hw = 0.5f * cell * (0.35f + 0.5f * static_cast<float>((h >> 8) & 15u) / 16.0f);
  const float hh = 0.5f * cell * (0.35f + 0.5f * static_cast<float>((h >> 12) & 15u) / 16.0f);
  const float du = std::abs(fu - 0.08f * cell - hw), dv = std::abs(fv - 0.08f * cell - hh);
  const float outer = box_coverage(du, dv, hw, hh, fw);
  if (outer <= 0.0f) return wall;
  const float inner = box_coverage(du, dv, hw - 0.025f, hh - 0.025f, fw);
  const MipTexture& t = textures.get(Material::patterned);
  const float content = t.sample(mip_level_for(fw * 300.0f, t.levels()), fu * 300.0f + static_cast<float>(h & 511u),
                                 fv * 300.0f + static_cast<float>((h >> 9) & 511u));
  const float frame = ((h >> 16) & 1u) ? 30.0f : 225.0f;
  return wall * (1.0f - outer) + frame * (outer - inner) + (128.0f + 1.4f * (content - 128.0f)) * inner;
}

inline float ceiling_panels(const Surface& s, float u, float v, float fw, float base) {
  constexpr float panel = 0.6f;
  const float fu = fract_of(u / panel) * panel, fv = fract_of(v / panel) * panel;
  const std::uint32_t h = cell_hash(s.hash, static_cast<int>(std::floor(u / panel)), static_cast<int>(std::floor(v / panel)));
  float value = base;
  if ((h & 7u) == 0) {  // a light fitting: bright, with dark louvres every 10 cm
    const float light = box_coverage(std::abs(fu - 0.3f), std::abs(fv - 0.3f), 0.22f, 0.22f, fw);
    const float louvre = fw < 0.05f ? coverage(std::abs(fract_of(fu / 0.1f) - 0.5f) * 0.1f, 0.0125f, fw) : 0.25f;
    value += light * (245.0f - 105.0f * louvre - value);
  }
  const float line = std::max(coverage(std::abs(fu - 0.01f), 0.01f, fw), coverage(std::abs(fv - 0.01f), 0.01f, fw));
  return value * (1.0f - 0.4f * line);
}

// A textured, lit, overlaid surface at supersampled position (i, j); `pixel` = samples per output
// pixel side (the footprint is that of an output pixel).
inline float shade_surface(const ViewPolygon& p, const TextureBank& textures, float i, float j, float pixel) {
  const Surface& s = *p.surface;
  const float w = p.a * i + p.b * j + p.c;
  const float inv = 1.0f / std::max(w, 1e-12f);
  const float nu = p.pu[0] * i + p.pu[1] * j + p.pu[2], nv = p.pv[0] * i + p.pv[1] * j + p.pv[2];
  const float u = nu * inv + p.pu[3], v = nv * inv + p.pv[3];
  // Footprint (m) from the derivatives of u, v by i and j.
  const float du_di = (p.pu[0] - nu * inv * p.a) * inv, dv_di = (p.pv[0] - nv * inv * p.a) * inv;
  const float du_dj = (p.pu[1] - nu * inv * p.b) * inv, dv_dj = (p.pv[1] - nv * inv * p.b) * inv;
  const float fw = pixel * std::sqrt(std::max(du_di * du_di + dv_di * dv_di, du_dj * du_dj + dv_dj * dv_dj));
  const MipTexture& t = textures.get(s.material);
  const float first = t.sample(mip_level_for(fw * s.texels_per_m, t.levels()), u * s.texels_per_m + s.offset_u,
                               v * s.texels_per_m + s.offset_v);
  const float k = s.texels_per_m * s.second_scale;
  const float u2 = (s.second_cos * u - s.second_sin * v) * k + s.offset_v;
  const float v2 = (s.second_sin * u + s.second_cos * v) * k + s.offset_u;
  const float second = t.sample(mip_level_for(fw * k, t.levels()), u2, v2);
  const float detail = 0.95f * (first - t.mean()) + 0.6f * (second - t.mean());
  const float base = s.bias + s.gain * detail;
  switch (s.overlay) {
    case Overlay::none: return s.shade * base;
    case Overlay::windows: return s.shade * windows(s, u, v, fw, base, detail);
    case Overlay::posters: return s.shade * posters(s, textures, u, v, fw, base);
    case Overlay::ceiling_panels: return s.shade * ceiling_panels(s, u, v, fw, base);
    case Overlay::kerb: return s.shade * base * (1.0f - 0.4f * coverage(std::abs(u - 0.075f), 0.075f, fw));
  }
  return s.shade * base;
}

// The sky at infinity (a cloud layer seen through the direction) or, below the horizon, a dim
// haze: a function of the direction only, so both eyes agree (disparity 0).
struct SkyFrame {
  float r[9];            // world-from-camera rotation, row-major
  float fx, fy, cx, cy;  // supersampled intrinsics
  bool has_sky;
};

inline float shade_sky(const SkyFrame& f, const TextureBank& textures, float i, float j, float pixel) {
  if (!f.has_sky) return 20.0f;
  const float x = (i - f.cx) / f.fx, y = (j - f.cy) / f.fy;
  const float dx = f.r[0] * x + f.r[1] * y + f.r[2], dy = f.r[3] * x + f.r[4] * y + f.r[5];
  const float dz = f.r[6] * x + f.r[7] * y + f.r[8];
  const float n = std::sqrt(dx * dx + dy * dy + dz * dz);
  const float e = std::max(std::abs(dz) / n, 0.03f);  // |sin(elevation)|, kept off the horizon
  constexpr float kTexelsPerUnit = 350.0f;
  const float q = kTexelsPerUnit / (e * n);
  const MipTexture& t = textures.get(Material::clouds);
  const float footprint = pixel * kTexelsPerUnit / (f.fx * e * e);
  const float cloud = t.sample(mip_level_for(footprint, t.levels()), dx * q, dy * q);
  if (dz >= 0) return 0.85f * cloud + 45.0f * (1.0f - e);
  return 0.45f * cloud + 25.0f;
}

}  // namespace porta::slam::render::detail
