// Reading and writing trajectories in the three formats users bring (DESIGN.md §6):
//  - TUM:   "t x y z qx qy qz qw" per line, '#' comments; time in seconds.
//  - KITTI: 12 numbers per line, the first three rows of T_world_cam row by row; no time (a separate
//           times.txt gives one time per line). Lines of 13 numbers "t r00 .. r23" are also read
//           (the shared kitti07_times_poses.txt).
//  - EuRoC: the ASL ground-truth CSV "timestamp_ns, px, py, pz, qw, qx, qy, qz[, ...]", '#' header;
//           extra columns (velocity, biases) are ignored. Written with exactly 8 columns.
// Every reading error names the file, the line number and what was wrong.
#pragma once

#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include "porta/slam/pose.hpp"

namespace porta::slam {

enum class TrajectoryFormat { tum, kitti, euroc };

/// "tum", "kitti", "euroc" (case-sensitive); nullopt otherwise.
std::optional<TrajectoryFormat> parse_trajectory_format(std::string_view name);
const char* to_string(TrajectoryFormat format);

/// A trajectory file that is missing, empty or malformed. what() names the file (and line).
class TrajectoryError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Guesses the format from the first data line: commas -> euroc; 8 numbers -> tum; 12 or 13 -> kitti.
TrajectoryFormat detect_trajectory_format(const std::string& path);

/// Bounds read_trajectory() enforces: |coordinate| in metres and |time| in seconds.
inline constexpr double kMaxTrajectoryCoordinateM = 1e9;
inline constexpr double kMaxTrajectoryTimeS = 1e11;

/// Reads a trajectory. For KITTI, `kitti_times_path` (optional) is a times.txt with one time per pose;
/// without it (and without a time column) has_times is false and time_s is the line index.
/// Quaternions are normalised; a zero quaternion or a non-rotation 3x3 block is an error, and so
/// are times that do not increase and values beyond the bounds above.
Trajectory read_trajectory(const std::string& path, TrajectoryFormat format,
                           const std::string& kitti_times_path = "");
/// Same, with the format detected by detect_trajectory_format().
Trajectory read_trajectory(const std::string& path);

/// Writes a trajectory (creates or truncates the file). KITTI writes poses only (times are the
/// caller's business, e.g. write_kitti_times). Numbers are written with enough digits to round-trip.
/// Throws TrajectoryError when the file cannot be written.
void write_trajectory(const std::string& path, const Trajectory& trajectory, TrajectoryFormat format);
/// One time per line (KITTI's times.txt).
void write_kitti_times(const std::string& path, const Trajectory& trajectory);

}  // namespace porta::slam
