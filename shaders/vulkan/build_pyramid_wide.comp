#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

// §3.2 pyramid, one level from the level above (pyramid_common.glsl).
layout(local_size_x = PORTA_TILE_W, local_size_y = PORTA_TILE_H) in;
#include "pyramid_common.glsl"
