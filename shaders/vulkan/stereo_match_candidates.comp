#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "common.glsl"
#include "list_common.glsl"
#include "stereo_common.glsl"

// §3.9 stereo matching, steps a-e (DESIGN.md §3.9, docs/ARCHITECTURE.md, backends/cpu/
// match_kernels.cpp match_left_keypoint): one workgroup per left list slot, launched over the
// capacity. Writes matches[i] ({-1, -1} for none) and sads[i] (-1 for none), and counts an accepted
// SAD in the median histogram (atomic increments commute: the counts do not depend on the order).
//  a, b: the invocations scan the whole right list with stride 64 (the cpu's row-bucketed search
//        visits the same candidates); the best is the minimum of (distance << 32 | index), the
//        cpu's "smallest distance, ties to the lower index" whatever the order, reduced through
//        shared memory (no subgroup operations: any subgroup size gives the same bytes).
//  c:    invocation k < 11 computes the centred SAD of increment k - 5.
//  d, e: invocation 0 picks the best increment (ties to the smaller one), fits the parabola and
//        scales the disparity to level 0, in 64-bit integers as contract_math.hpp.
layout(local_size_x = 64) in;

#include "stereo_match_body.glsl"
