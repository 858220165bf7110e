#include "porta/slam/pose.hpp"

#include <algorithm>
#include <cmath>

namespace porta::slam {

double Trajectory::path_length_m() const {
  double length = 0.0;
  for (std::size_t i = 1; i < poses.size(); ++i) {
    length += (poses[i].pose.translation() - poses[i - 1].pose.translation()).norm();
  }
  return length;
}

double rotation_angle_rad(const Eigen::Matrix3d& rotation) {
  // acos of the trace loses precision near 0 and pi; atan2 of (sin, cos) does not.
  const double cos_angle = 0.5 * (rotation.trace() - 1.0);
  const Eigen::Vector3d axis_times_sin(rotation(2, 1) - rotation(1, 2), rotation(0, 2) - rotation(2, 0),
                                       rotation(1, 0) - rotation(0, 1));
  const double sin_angle = 0.5 * axis_times_sin.norm();
  return std::atan2(sin_angle, std::clamp(cos_angle, -1.0, 1.0));
}

}  // namespace porta::slam
