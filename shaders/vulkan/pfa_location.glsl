// §3.5 PFA's projection to level 0, shared by pfa_common.glsl and fast_cull.comp (which does
// step A itself): include it after a parameter block `p` with int scales[PORTA_MAX_LEVELS] (S[n],
// Q16), width0 and height0. Needs GL_EXT_shader_explicit_arithmetic_types_int64.
//
// L = Y * width0 + X with X = (x * S[level]) >> 16 and Y likewise, clamped to the level-0 image
// (64-bit products of the sign-extended scale, as the cpu backend).
#ifndef PFA_LOCATION_GLSL
#define PFA_LOCATION_GLSL
uint pfa_location(uvec2 kp) {
  const uint64_t scale = uint64_t(int64_t(p.scales[kp_level(kp)]));
  const uint64_t x = min((uint64_t(kp_x(kp)) * scale) >> 16, uint64_t(p.width0 - 1));
  const uint64_t y = min((uint64_t(kp_y(kp)) * scale) >> 16, uint64_t(p.height0 - 1));
  return uint(y * uint64_t(p.width0) + x);
}
#endif
