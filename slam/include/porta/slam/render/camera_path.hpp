// Camera paths for the renderer: built-in demo paths, frame selection (stride, resampling at a
// frame rate with linear/slerp interpolation), and the conventions that turn a trajectory file's
// poses into camera poses of the z-up render world (DESIGN.md §7).
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "porta/slam/pose.hpp"

namespace porta::slam::render {

enum class BuiltinPath { street_loop, room_orbit };
/// "street-loop", "room-orbit"; nullopt otherwise.
std::optional<BuiltinPath> parse_builtin_path(std::string_view name);
const char* to_string(BuiltinPath path);

/// A built-in path as camera poses (x right, y down, z forward) in a z-up world, with times.
///  - street-loop: a closed drive of about 490 m at 8 m/s, 10 Hz (612 frames), camera 1.65 m
///    above the road; ends where it started, looking the same way.
///  - room-orbit: a drone-like 60 s flight at 20 Hz in an 8 x 8 m room, at 0.9-1.9 m height,
///    looking around (yaw, some pitch and roll), ending where it started.
Trajectory builtin_path(BuiltinPath path);

/// The pose a fraction `s` of the way from `a` to `b` (linear in translation, slerp in rotation;
/// s outside [0, 1] extrapolates the translation and the rotation).
SE3 interpolate_pose(const SE3& a, const SE3& b, double s);
/// Poses at t0, t0 + 1/fps, ... up to the last time, interpolated; needs has_times and fps > 0.
Trajectory resample(const Trajectory& trajectory, double fps);
/// Every `stride`-th pose from the first.
Trajectory take_every(const Trajectory& trajectory, int stride);

/// A world axis given as "x", "-x", "y", "-y", "z", "-z"; nullopt otherwise.
std::optional<Eigen::Vector3d> parse_axis(std::string_view name);
/// A rotation taking the input world's `up` axis to +z (the render world), for up = +-x, +-y, +-z.
Eigen::Matrix3d render_from_input(const Eigen::Vector3d& up);

/// EuRoC MAV cam0's body-to-camera transform T_BS (T_body_cam0), from the dataset's
/// mav0/cam0/sensor.yaml: camera poses of a drone path are T_world_body * T_body_cam0.
SE3 euroc_T_body_cam0();

}  // namespace porta::slam::render
