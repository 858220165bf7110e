// Rigid poses and time-stamped trajectories: the currency of the renderer, the dataset readers, the
// evaluation and (later) tracking. A pose is T_world_frame: it maps points of the frame (a camera or
// a body) into the world, so its translation is the frame's position in the world.
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <vector>

namespace porta::slam {

/// A rigid transform (rotation + translation). Always kept orthonormal by construction.
using SE3 = Eigen::Isometry3d;

/// T_world_frame at time `time_s` (seconds; the time base is the file's, e.g. EuRoC ns / 1e9).
struct StampedPose {
  double time_s = 0.0;
  SE3 pose = SE3::Identity();
};

/// A trajectory in time order. `has_times` is false when the source had no timestamps (a KITTI
/// pose file without times.txt): time_s is then the frame index and association is by index.
struct Trajectory {
  std::vector<StampedPose> poses;
  bool has_times = true;

  std::size_t size() const { return poses.size(); }
  bool empty() const { return poses.empty(); }
  /// Sum of the distances between consecutive positions (metres).
  double path_length_m() const;
};

/// Rotation angle of a rotation matrix in radians, in [0, pi], robust near 0 and pi.
double rotation_angle_rad(const Eigen::Matrix3d& rotation);

}  // namespace porta::slam
