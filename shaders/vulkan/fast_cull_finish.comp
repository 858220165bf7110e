#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "common.glsl"

// fast_cull.comp (FAST, culling and PFA's step A in one dispatch) whose last workgroup to finish
// also runs PFA's steps B and C and the compaction (pfa_compact_group.comp's work, with 256
// invocations): detection in one dispatch for up to a few hundred cells (the backend's
// detect_keypoints on GPUs). The same bytes as fast_cull then pfa_compact_group.
#define FAST_CULL_FINISH
#include "fast_cull_body.glsl"
