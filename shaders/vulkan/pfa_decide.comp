#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "common.glsl"
#include "pfa_common.glsl"

// §3.5 PFA, step B: rejected[i] = 1 when a location within `reach` of the keypoint's L (clipped to
// the level-0 image) scores strictly more than L, else 0. Cells and maps are only read.
void main() {
  const uint i = porta_linear_index();
  if (i >= uint(p.total_cells)) return;
  uvec2 kp;
  uint reject = 0u;
  if (pfa_keypoint(i, kp)) {
    const uint l = pfa_location(kp);
    const uint own = pfa_score(l);
    const int x = int(l % uint(p.width0));
    const int y = int(l / uint(p.width0));
    const int xa = max(0, x - p.reach), xb = min(p.width0 - 1, x + p.reach);
    const int ya = max(0, y - p.reach), yb = min(p.height0 - 1, y + p.reach);
    for (int wy = ya; wy <= yb && reject == 0u; ++wy) {
      const uint row = uint(wy) * uint(p.width0);
      for (int wx = xa; wx <= xb; ++wx) {
        if (pfa_score(row + uint(wx)) > own) {
          reject = 1u;
          break;
        }
      }
    }
  }
  rejected[i] = uint8_t(reject);
}
