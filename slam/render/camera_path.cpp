// Built-in paths, resampling and pose conventions (camera_path.hpp).
#include "porta/slam/render/camera_path.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace porta::slam::render {

namespace {

constexpr double kPi = 3.14159265358979323846;

// A camera pose at `eye` looking along `forward` (world), with roll about it; y points "down".
SE3 look_along(const Eigen::Vector3d& eye, const Eigen::Vector3d& forward, double roll = 0.0) {
  const Eigen::Vector3d z = forward.normalized();
  Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ());  // right, horizontal
  if (x.norm() < 1e-9) x = Eigen::Vector3d::UnitX();
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);  // down-ish
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = y;
  R.col(2) = z;
  R = R * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  SE3 T = SE3::Identity();
  T.linear() = R;
  T.translation() = eye;
  return T;
}

// The street loop's centre line: a rounded rectangle 170 x 90 m (corner radius 18 m), driven
// counter-clockwise from the middle of its south side; arc length -> position and heading.
struct RoundedRectangle {
  double half_x = 85.0, half_y = 45.0, radius = 18.0;
  double straight_x() const { return 2 * (half_x - radius); }
  double straight_y() const { return 2 * (half_y - radius); }
  double length() const { return 2 * straight_x() + 2 * straight_y() + 2 * kPi * radius; }
  void at(double s, Eigen::Vector2d& p, Eigen::Vector2d& heading) const {
    s = std::fmod(std::fmod(s, length()) + length(), length());
    const double quarter = kPi * radius / 2;
    const double sides[4] = {straight_x(), straight_y(), straight_x(), straight_y()};
    // Start at the middle of the south side heading +x.
    double offset = straight_x() / 2;
    s += offset;
    const Eigen::Vector2d corners[4] = {{half_x - radius, -half_y + radius}, {half_x - radius, half_y - radius},
                                        {-half_x + radius, half_y - radius}, {-half_x + radius, -half_y + radius}};
    const Eigen::Vector2d starts[4] = {{-half_x + radius, -half_y}, {half_x, -half_y + radius},
                                       {half_x - radius, half_y}, {-half_x, half_y - radius}};
    for (int side = 0;; side = (side + 1) % 4) {
      const double direction_angle = side * kPi / 2;
      const Eigen::Vector2d dir(std::cos(direction_angle), std::sin(direction_angle));
      if (s < sides[side]) {
        p = starts[side] + s * dir;
        heading = dir;
        return;
      }
      s -= sides[side];
      if (s < quarter) {
        const double a = direction_angle - kPi / 2 + s / radius;
        p = corners[side] + radius * Eigen::Vector2d(std::cos(a), std::sin(a));
        heading = Eigen::Vector2d(-std::sin(a), std::cos(a));
        return;
      }
      s -= quarter;
    }
  }
};

}  // namespace

std::optional<BuiltinPath> parse_builtin_path(std::string_view name) {
  if (name == "street-loop") return BuiltinPath::street_loop;
  if (name == "room-orbit") return BuiltinPath::room_orbit;
  return std::nullopt;
}

const char* to_string(BuiltinPath path) { return path == BuiltinPath::street_loop ? "street-loop" : "room-orbit"; }

Trajectory builtin_path(BuiltinPath path) {
  Trajectory t;
  if (path == BuiltinPath::street_loop) {
    const RoundedRectangle loop;
    constexpr double speed = 8.0, rate = 10.0;
    const int frames = static_cast<int>(std::round(loop.length() / speed * rate));
    const double step = loop.length() / frames;  // so that the last frame + 1 step closes the loop
    for (int k = 0; k <= frames; ++k) {
      Eigen::Vector2d p, h;
      loop.at(k * step, p, h);
      // Keep to the right half of the road (1.5 m right of the centre line), small weave.
      const Eigen::Vector2d right(h.y(), -h.x());
      const Eigen::Vector2d pos = p + right * (1.5 + 0.3 * std::sin(k * 2 * kPi / frames * 7));
      const double pitch = 0.01 * std::sin(k * 2 * kPi / frames * 11);
      t.poses.push_back({k / rate, look_along({pos.x(), pos.y(), 1.65}, {h.x(), h.y(), pitch})});
    }
    return t;
  }
  constexpr double rate = 20.0, duration = 60.0;
  const int frames = static_cast<int>(duration * rate);
  for (int k = 0; k <= frames; ++k) {
    const double s = 2 * kPi * k / frames;  // one period over the flight: it ends where it began
    const Eigen::Vector3d eye(1.8 * std::sin(s) + 0.4 * std::sin(3 * s), 1.4 * std::sin(2 * s) + 0.3 * std::cos(s),
                              1.4 + 0.45 * std::sin(3 * s + 0.5));
    const double yaw = s * 2 + 0.6 * std::sin(2 * s);  // looks all around the room twice
    const Eigen::Vector3d forward(std::cos(yaw), std::sin(yaw), -0.12 + 0.15 * std::sin(4 * s));
    t.poses.push_back({k / rate, look_along(eye, forward, 0.08 * std::sin(5 * s))});
  }
  return t;
}

SE3 interpolate_pose(const SE3& a, const SE3& b, double s) {
  const Eigen::Quaterniond qa(a.rotation()), qb(b.rotation());
  SE3 out = SE3::Identity();
  if (s >= 0.0 && s <= 1.0) {
    out.linear() = qa.slerp(s, qb).toRotationMatrix();
  } else {  // extrapolate: apply the relative rotation s times
    const Eigen::AngleAxisd rel(qa.conjugate() * qb);
    out.linear() = (qa * Eigen::Quaterniond(Eigen::AngleAxisd(rel.angle() * s, rel.axis()))).toRotationMatrix();
  }
  out.translation() = a.translation() + s * (b.translation() - a.translation());
  return out;
}

Trajectory resample(const Trajectory& trajectory, double fps) {
  if (!(fps > 0.0)) throw std::invalid_argument("resample: fps must be > 0");
  Trajectory out;
  if (trajectory.empty()) return out;
  const auto& p = trajectory.poses;
  const double t0 = p.front().time_s, t1 = p.back().time_s;
  std::size_t seg = 0;
  for (long long n = 0;; ++n) {
    const double t = t0 + static_cast<double>(n) / fps;
    if (t > t1 + 1e-9) break;
    while (seg + 2 < p.size() && p[seg + 1].time_s < t) ++seg;
    if (p.size() == 1) {
      out.poses.push_back({t, p[0].pose});
      break;
    }
    const double dt = p[seg + 1].time_s - p[seg].time_s;
    const double s = dt > 0 ? std::clamp((t - p[seg].time_s) / dt, 0.0, 1.0) : 0.0;
    out.poses.push_back({t, interpolate_pose(p[seg].pose, p[seg + 1].pose, s)});
  }
  return out;
}

Trajectory take_every(const Trajectory& trajectory, int stride) {
  if (stride < 1) throw std::invalid_argument("take_every: stride must be >= 1");
  Trajectory out;
  out.has_times = trajectory.has_times;
  for (std::size_t k = 0; k < trajectory.poses.size(); k += static_cast<std::size_t>(stride)) out.poses.push_back(trajectory.poses[k]);
  return out;
}

std::optional<Eigen::Vector3d> parse_axis(std::string_view name) {
  const bool negative = !name.empty() && name[0] == '-';
  if (negative || (!name.empty() && name[0] == '+')) name.remove_prefix(1);
  Eigen::Vector3d a;
  if (name == "x") a = Eigen::Vector3d::UnitX();
  else if (name == "y") a = Eigen::Vector3d::UnitY();
  else if (name == "z") a = Eigen::Vector3d::UnitZ();
  else return std::nullopt;
  return negative ? Eigen::Vector3d(-a) : a;
}

Eigen::Matrix3d render_from_input(const Eigen::Vector3d& up) {
  // Rows: the render world's x, y, z axes in input coordinates; z = up, x = the next axis after up.
  const Eigen::Vector3d z = up.normalized();
  Eigen::Vector3d x = std::abs(z.x()) > 0.5 ? Eigen::Vector3d::UnitY() : Eigen::Vector3d::UnitX();
  x = (x - x.dot(z) * z).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d R;
  R.row(0) = x.transpose();
  R.row(1) = y.transpose();
  R.row(2) = z.transpose();
  return R;
}

SE3 euroc_T_body_cam0() {
  Eigen::Matrix4d m;
  m << 0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,  //
      0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,       //
      -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949,   //
      0.0, 0.0, 0.0, 1.0;
  // Re-orthonormalise (the file's 12 digits leave it 1e-12 off a rotation).
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m.topLeftCorner<3, 3>(), Eigen::ComputeFullU | Eigen::ComputeFullV);
  SE3 T = SE3::Identity();
  T.linear() = svd.matrixU() * svd.matrixV().transpose();
  T.translation() = m.topRightCorner<3, 1>();
  return T;
}

}  // namespace porta::slam::render
