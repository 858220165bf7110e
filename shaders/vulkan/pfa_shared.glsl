// §3.5 PFA of at most PFA_SHARED_CELLS cells in one workgroup, in shared memory instead of the
// level-0 maps (pfa_compact_group.comp, pfa_group.comp; include after pfa_common.glsl, with the
// cells buffer `coherent` where other invocations read them after it). Each keypoint's score is
// summed over the keypoints projected to its own location, and it is rejected when a keypoint
// within `reach` of its location in x and y scores strictly more: locations without a keypoint
// score 0, which no keypoint's own score is below, so this is the maps' decision (clipping the
// window to the image changes nothing, every location being inside it). O(n^2) on one
// multiprocessor, so only for small cell arrays, where it saves the maps' global round trips.
#define PFA_SHARED_CELLS 256
const uint kPfaNoLocation = 0xFFFFFFFFu;
shared uint pfa_loc[PFA_SHARED_CELLS];  // L, or kPfaNoLocation: not a keypoint PFA looks at
shared uint pfa_x[PFA_SHARED_CELLS];
shared uint pfa_y[PFA_SHARED_CELLS];
shared uint pfa_value[PFA_SHARED_CELLS];  // response | level << 16
shared uint pfa_shared_score[PFA_SHARED_CELLS];

// Every invocation of the workgroup calls it (barriers inside); `total` <= PFA_SHARED_CELLS.
void pfa_in_shared(uint total, uint t, uint threads) {
  for (uint i = t; i < total; i += threads) {
    uvec2 kp;
    uint l = kPfaNoLocation;
    if (pfa_keypoint(i, kp)) {
      l = pfa_location(kp);
      pfa_x[i] = l % uint(p.width0);
      pfa_y[i] = l / uint(p.width0);
      pfa_value[i] = kp_response(kp) | (kp_level(kp) << 16);
    }
    pfa_loc[i] = l;
  }
  barrier();
  // score(L) = (sum of the responses at L) * (distinct levels at L), in uint32 as the maps.
  for (uint i = t; i < total; i += threads) {
    const uint l = pfa_loc[i];
    if (l == kPfaNoLocation) continue;
    uint sum = 0u, levels = 0u;
    for (uint j = 0u; j < total; ++j) {
      if (pfa_loc[j] != l) continue;
      sum += pfa_value[j] & 0xFFFFu;
      levels |= 1u << (pfa_value[j] >> 16);
    }
    pfa_shared_score[i] = sum * uint(bitCount(levels));
  }
  barrier();
  for (uint i = t; i < total; i += threads) {
    if (pfa_loc[i] == kPfaNoLocation) continue;
    const uint own = pfa_shared_score[i];
    const int x = int(pfa_x[i]), y = int(pfa_y[i]);
    bool reject = false;
    for (uint j = 0u; j < total; ++j) {
      if (pfa_loc[j] == kPfaNoLocation) continue;
      reject = reject || (abs(int(pfa_x[j]) - x) <= p.reach && abs(int(pfa_y[j]) - y) <= p.reach &&
                          pfa_shared_score[j] > own);
    }
    if (reject) cells[i] = uvec2(0u);
  }
}
