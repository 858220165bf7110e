// Projection matching for tracking (DESIGN.md §3.10): map points already projected into a frame
// (ProjectionQuery: level-0 position in 1/256 px, window radius, level range) are matched against
// the frame's keypoints by Hamming distance. The same search runs either on a compute backend
// (Backend::projection_match) or on the host; both give the same result bytes, so tracking gives
// the same trajectory whichever is used (SlamSettings::projection_on_backend).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "porta/backend.hpp"
#include "porta/keypoint.hpp"
#include "porta/slam/frame.hpp"

namespace porta::slam {

/// Level-0 position in 1/256 px of a level-n coordinate: (c * S[n] + 128) >> 8 (docs/ARCHITECTURE.md).
inline std::int32_t level0_q8(int coordinate, std::int32_t scale_q16) {
  return static_cast<std::int32_t>((static_cast<std::int64_t>(coordinate) * scale_q16 + 128) >> 8);
}

/// The frame's keypoints in the kernel's format: `features.keypoints` when it has one per feature
/// (features from the frontend), otherwise uv rounded to the keypoint's level grid.
std::vector<Keypoint> kernel_keypoints(const FrameFeatures& features,
                                       const std::vector<std::int32_t>& scales_q16);

/// Runs the projection-match search for one frame at a time. `backend` null: on the host.
class ProjectionMatcher {
 public:
  /// `queue` (with a backend): the backend queue match() sends its transfers and kernel to
  /// (Frontend::spare_queue(), so that they do not wait behind frames in flight); -1 = whichever
  /// queue is current. BackendError when the backend has no such queue.
  ProjectionMatcher(Backend* backend, std::vector<std::int32_t> scales_q16, int queue = -1);
  ~ProjectionMatcher();
  ProjectionMatcher(const ProjectionMatcher&) = delete;
  ProjectionMatcher& operator=(const ProjectionMatcher&) = delete;

  /// The frame searched by the next match() calls; on a backend its keypoints and descriptors are
  /// uploaded once here. `keypoints` and `descriptors` have one entry per feature.
  void set_frame(std::vector<Keypoint> keypoints, const std::vector<Descriptor>& descriptors);
  /// One result per query (DESIGN.md §3.10): best keypoint (ties to the lower index), best and
  /// second-best distance.
  std::vector<ProjectionResult> match(const std::vector<ProjectionQuery>& queries,
                                      const std::vector<Descriptor>& query_descriptors);
  bool on_backend() const { return backend_ != nullptr; }

 private:
  struct Placed {  // a keypoint at level 0, for the host search
    std::int32_t v_q8, u_q8;
    int index;
    int level;
  };
  struct DeviceSide;
  std::vector<ProjectionResult> match_on_host(const std::vector<ProjectionQuery>& queries,
                                              const std::vector<Descriptor>& query_descriptors) const;

  Backend* backend_;
  std::vector<std::int32_t> scales_q16_;
  int queue_ = -1;
  std::vector<Descriptor> descriptors_;  // host search only
  std::vector<Placed> by_row_;           // host search only: sorted by row, then index
  std::unique_ptr<DeviceSide> device_;
};

}  // namespace porta::slam
