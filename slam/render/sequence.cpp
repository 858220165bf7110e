// Planning and rendering of a stereo sequence (sequence.hpp): defaults, frame selection, world and
// texture construction, and the per-frame image effects (motion blur, exposure, noise).
#include "porta/slam/render/sequence.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <thread>

#include "porta/slam/render/hash.hpp"

namespace porta::slam::render {

namespace {

constexpr double kPi = 3.14159265358979323846;

std::string fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

void require(bool ok, const std::string& message) {
  if (!ok) throw RenderError(message);
}

void validate_options(const RenderOptions& o) {
  require(o.supersample >= 1 && o.supersample <= 4, "supersample must be in [1, 4], got " + std::to_string(o.supersample));
  require(o.stride >= 1, "stride must be >= 1, got " + std::to_string(o.stride));
  require(!o.fps || (*o.fps > 0.0 && *o.fps <= 1000.0), "fps must be in (0, 1000], got " + fmt(o.fps.value_or(0)));
  require(o.noise_sigma >= 0.0 && o.noise_sigma <= 64.0, "noise sigma must be in [0, 64] grey levels, got " + fmt(o.noise_sigma));
  require(o.exposure_amplitude >= 0.0 && o.exposure_amplitude <= 0.9,
          "exposure amplitude must be in [0, 0.9], got " + fmt(o.exposure_amplitude));
  require(o.motion_blur >= 0.0 && o.motion_blur <= 1.0, "motion blur (shutter fraction) must be in [0, 1], got " + fmt(o.motion_blur));
  require(o.blur_samples >= 2 && o.blur_samples <= 64, "blur samples must be in [2, 64], got " + std::to_string(o.blur_samples));
  require(o.threads >= 0 && o.threads <= 1024, "threads must be in [0, 1024] (0 = all hardware threads), got " + std::to_string(o.threads));
  require(o.texture_size >= 16 && o.texture_size <= 4096 && (o.texture_size & (o.texture_size - 1)) == 0,
          "texture size must be a power of two in [16, 4096], got " + std::to_string(o.texture_size));
  require(!o.count || *o.count >= 1, "count must be >= 1");
  require(!(o.builtin && !o.trajectory_path.empty()), "give either a trajectory file or a built-in path, not both");
}

StereoCamera default_camera(WorldKind kind) {
  StereoCamera c;
  if (kind == WorldKind::street) {  // KITTI odometry (sequences 00-02) rectified camera 0/1
    c.width = 1242, c.height = 375, c.fx = c.fy = 718.856, c.cx = 607.1928, c.cy = 185.2157, c.baseline_m = 0.537;
  } else {  // EuRoC MAV VI-sensor, rectified
    c.width = 752, c.height = 480, c.fx = c.fy = 458.0, c.cx = 376.0, c.cy = 240.0, c.baseline_m = 0.11;
  }
  return c;
}

SE3 with_rotation(const Eigen::Matrix3d& R, const SE3& T) {
  SE3 out = SE3::Identity();
  out.linear() = R * T.rotation();
  out.translation() = R * T.translation();
  return out;
}

// 4096 standard normal values (Box-Muller from a fixed seed, normalised to mean 0, sd 1).
const std::array<float, 4096>& gaussian_table() {
  static const std::array<float, 4096> table = [] {
    std::array<double, 4096> v{};
    HashRng rng(0x6A55);
    for (std::size_t i = 0; i < v.size(); i += 2) {
      const double u1 = std::max(rng.uniform(), 1e-12), u2 = rng.uniform();
      const double r = std::sqrt(-2.0 * std::log(u1));
      v[i] = r * std::cos(2 * kPi * u2);
      v[i + 1] = r * std::sin(2 * kPi * u2);
    }
    double mean = 0, sq = 0;
    for (double x : v) mean += x;
    mean /= v.size();
    for (double x : v) sq += (x - mean) * (x - mean);
    const double sd = std::sqrt(sq / v.size());
    std::array<float, 4096> t{};
    for (std::size_t i = 0; i < v.size(); ++i) t[i] = static_cast<float>((v[i] - mean) / sd);
    return t;
  }();
  return table;
}

}  // namespace

SequencePlan plan_sequence(const RenderOptions& options) {
  validate_options(options);
  SequencePlan plan;
  RenderOptions& o = plan.options;
  o = options;

  Trajectory source;
  bool body = false;
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  if (!o.trajectory_path.empty()) {
    const TrajectoryFormat format = o.format ? *o.format : detect_trajectory_format(o.trajectory_path);
    o.format = format;
    source = read_trajectory(o.trajectory_path, format, o.kitti_times_path);
    require(!source.empty(), "trajectory " + o.trajectory_path + " has no poses");
    if (!source.has_times) {  // a KITTI pose file without times.txt: KITTI's 10 Hz
      for (std::size_t k = 0; k < source.poses.size(); ++k) source.poses[k].time_s = static_cast<double>(k) / 10.0;
      source.has_times = true;
    }
    body = o.poses_are_body.value_or(format != TrajectoryFormat::kitti);
    up = o.up.value_or(format == TrajectoryFormat::kitti ? Eigen::Vector3d(0, -1, 0) : Eigen::Vector3d::UnitZ());
    plan.source = o.trajectory_path + " (" + to_string(format) + ", " + (body ? "body" : "camera") + " poses)";
  } else {
    require(!o.poses_are_body || !*o.poses_are_body, "built-in paths are camera paths: --pose-is body does not apply");
    require(!o.up || o.up->isApprox(Eigen::Vector3d::UnitZ()), "built-in paths are z-up: --up does not apply");
    if (!o.builtin && !o.count) o.count = 200;  // the default run: a short part of the street loop
    if (!o.builtin) o.builtin = BuiltinPath::street_loop;
    source = builtin_path(*o.builtin);
    plan.source = std::string(to_string(*o.builtin)) + " (built-in path)";
  }
  for (std::size_t k = 1; k < source.poses.size(); ++k)
    require(source.poses[k].time_s >= source.poses[k - 1].time_s,
            "trajectory " + plan.source + ": times go backwards at pose " + std::to_string(k + 1));
  o.poses_are_body = body;
  o.up = up;

  plan.T_body_cam0 = euroc_T_body_cam0();
  const Eigen::Matrix3d R = render_from_input(up);
  const auto input_cam = [&](const SE3& pose) -> SE3 { return body ? SE3(pose * plan.T_body_cam0) : pose; };
  const auto input_body = [&](const SE3& pose) -> SE3 { return body ? pose : SE3(pose * plan.T_body_cam0.inverse()); };

  // The world is built from the whole source path, whatever frames are rendered.
  PathSamples path;
  for (const auto& p : source.poses) path.positions.push_back(R * input_cam(p.pose).translation());
  Eigen::Vector3d lo = path.positions[0], hi = lo;
  for (const auto& p : path.positions) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  plan.world_kind = o.world;
  if (plan.world_kind == WorldKind::automatic) {
    if (o.builtin) plan.world_kind = *o.builtin == BuiltinPath::street_loop ? WorldKind::street : WorldKind::room;
    else plan.world_kind = std::max(hi.x() - lo.x(), hi.y() - lo.y()) > 30.0 ? WorldKind::street : WorldKind::room;
  }
  o.world = plan.world_kind;
  plan.layout = o.layout.value_or(plan.world_kind == WorldKind::street ? Layout::kitti : Layout::euroc);
  o.layout = plan.layout;

  // Camera.
  StereoCamera cam = default_camera(plan.world_kind);
  if (o.width || o.height) {
    require(o.width && o.height, "give both width and height");
    // Keep the field of view: scale a default principal point with the size if none was given.
    if (!o.cx) cam.cx = (cam.cx + 0.5) * *o.width / cam.width - 0.5;
    if (!o.cy) cam.cy = (cam.cy + 0.5) * *o.height / cam.height - 0.5;
    if (!o.fx) cam.fx *= static_cast<double>(*o.width) / cam.width;
    if (!o.fy) cam.fy *= static_cast<double>(*o.width) / cam.width;
    cam.width = *o.width;
    cam.height = *o.height;
  }
  if (o.fx) cam.fx = *o.fx;
  if (o.fy) cam.fy = *o.fy;
  if (o.cx) cam.cx = *o.cx;
  if (o.cy) cam.cy = *o.cy;
  if (o.baseline_m) cam.baseline_m = *o.baseline_m;
  try {
    cam.validate();
  } catch (const std::invalid_argument& e) {
    throw RenderError(std::string("bad camera: ") + e.what());
  }
  require(cam.cx >= 0 && cam.cx <= cam.width - 1 && cam.cy >= 0 && cam.cy <= cam.height - 1,
          "bad camera: the principal point (" + fmt(cam.cx) + ", " + fmt(cam.cy) + ") must lie inside the " +
              std::to_string(cam.width) + "x" + std::to_string(cam.height) + " image");
  require(cam.baseline_m <= 10.0, "bad camera: baseline " + fmt(cam.baseline_m) + " m is above 10 m");
  plan.camera = cam;

  // Frames: resample, stride, range.
  Trajectory sampled = o.fps ? resample(source, *o.fps) : source;
  sampled = take_every(sampled, o.stride);
  const std::size_t n = sampled.size();
  require(o.first < n, "first frame " + std::to_string(o.first) + " is outside the trajectory: it has " + std::to_string(n) +
                           " frames after sampling (first must be in [0, " + std::to_string(n - 1) + "])");
  const std::size_t count = o.count.value_or(n - o.first);
  require(o.first + count <= n, "frame range [" + std::to_string(o.first) + ", " + std::to_string(o.first + count) +
                                    ") is outside the trajectory: it has " + std::to_string(n) + " frames after sampling");
  o.count = count;
  plan.start_time_s = sampled.poses.front().time_s;
  for (std::size_t k = o.first; k < o.first + count; ++k) {
    PlannedFrame f;
    f.index = k;
    f.time_s = sampled.poses[k].time_s;
    f.input_cam = input_cam(sampled.poses[k].pose);
    f.input_body = input_body(sampled.poses[k].pose);
    f.render_cam = with_rotation(R, f.input_cam);
    f.render_cam_previous = k > 0 ? with_rotation(R, input_cam(sampled.poses[k - 1].pose)) : f.render_cam;
    plan.frames.push_back(f);
  }
  std::vector<double> gaps;
  for (std::size_t k = 1; k < n; ++k) gaps.push_back(sampled.poses[k].time_s - sampled.poses[k - 1].time_s);
  if (!gaps.empty()) {
    std::nth_element(gaps.begin(), gaps.begin() + static_cast<std::ptrdiff_t>(gaps.size() / 2), gaps.end());
    const double gap = gaps[gaps.size() / 2];
    plan.rate_hz = gap > 0 ? 1.0 / gap : 10.0;
  }

  if (o.threads == 0) o.threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  plan.textures = std::make_shared<const TextureBank>(o.seed, o.texture_size, o.threads);
  plan.world = std::make_shared<const World>(plan.world_kind == WorldKind::street ? build_street_world(path, o.seed)
                                                                                  : build_room_world(path, o.seed));
  return plan;
}

StereoFrame render_frame(const SequencePlan& plan, std::size_t k, Rasterizer& rasterizer) {
  const RenderOptions& o = plan.options;
  const PlannedFrame& f = plan.frames.at(k);
  const StereoCamera& c = plan.camera;
  const PinholeView view{c.width, c.height, c.fx, c.fy, c.cx, c.cy};
  const std::size_t pixels = static_cast<std::size_t>(c.width) * c.height;

  // Exposure: smooth gain and offset changes over time (two incommensurate periods).
  const double t = f.time_s - plan.start_time_s;
  const double phase[3] = {2 * kPi * unit_of(hash_of(o.seed, 0xE1)), 2 * kPi * unit_of(hash_of(o.seed, 0xE2)),
                           2 * kPi * unit_of(hash_of(o.seed, 0xE3))};
  const double A = o.exposure_amplitude;
  const float gain = static_cast<float>(1.0 + A * (0.6 * std::sin(2 * kPi * t / 7.3 + phase[0]) + 0.4 * std::sin(2 * kPi * t / 17.9 + phase[1])));
  const float offset = static_cast<float>(25.0 * A * std::sin(2 * kPi * t / 11.3 + phase[2]));

  StereoFrame out;
  std::vector<float> image, accumulated;
  for (int eye = 0; eye < 2; ++eye) {
    const SE3 right_of_left = SE3(Eigen::Translation3d(eye * c.baseline_m, 0, 0));
    const bool blur = o.motion_blur > 0.0 && !f.render_cam_previous.isApprox(f.render_cam, 1e-12);
    if (!blur) {
      rasterizer.render(*plan.world, *plan.textures, view, f.render_cam * right_of_left, o.supersample, accumulated);
    } else {
      accumulated.assign(pixels, 0.0f);
      for (int m = 0; m < o.blur_samples; ++m) {
        const double s = 1.0 - o.motion_blur * (1.0 - static_cast<double>(m) / (o.blur_samples - 1));
        const SE3 pose = interpolate_pose(f.render_cam_previous, f.render_cam, s) * right_of_left;
        rasterizer.render(*plan.world, *plan.textures, view, pose, o.supersample, image);
        for (std::size_t p = 0; p < pixels; ++p) accumulated[p] += image[p];
      }
      const float norm = 1.0f / static_cast<float>(o.blur_samples);
      for (float& v : accumulated) v *= norm;
    }
    Image result(c.width, c.height);
    const auto& gauss = gaussian_table();
    const float sigma = static_cast<float>(o.noise_sigma);
    for (int y = 0; y < c.height; ++y) {
      HashRng rng(hash_of(o.seed, static_cast<std::int64_t>(f.index), eye, y));
      std::uint64_t bits = 0;
      int left_in_bits = 0;
      std::uint8_t* row = result.row(y);
      const float* src = accumulated.data() + static_cast<std::size_t>(y) * c.width;
      for (int x = 0; x < c.width; ++x) {
        float v = gain * src[x] + offset;
        if (sigma > 0.0f) {
          if (left_in_bits == 0) bits = rng.next(), left_in_bits = 5;
          v += sigma * gauss[bits & 4095u];
          bits >>= 12;
          --left_in_bits;
        }
        v = std::clamp(v, 0.0f, 255.0f);
        row[x] = static_cast<std::uint8_t>(v + 0.5f);
      }
    }
    (eye == 0 ? out.left : out.right) = std::move(result);
  }
  return out;
}

}  // namespace porta::slam::render
