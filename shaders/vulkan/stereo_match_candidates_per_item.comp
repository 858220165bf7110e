#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "common.glsl"
#include "list_common.glsl"
#include "stereo_common.glsl"

// §3.9 stereo matching, steps a-e, for CPU devices (lavapipe): one invocation per left list slot,
// launched over the capacity (Work::items), which scans the whole right list, computes the 11
// centred SADs and finishes the slot alone, without a workgroup's barriers. The same steps and
// bytes as stereo_match_candidates.comp (stereo_match_body.glsl).
#define STEREO_PER_ITEM
layout(local_size_x = 64) in;

#include "stereo_match_body.glsl"
