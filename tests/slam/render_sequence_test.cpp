// Rendered sequences: determinism (same options -> same bytes, whatever the thread count),
// revisits, the KITTI and EuRoC layouts on disk, and errors for bad options (slam/render).
#if PORTA_RENDER_BUILT
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "porta/slam/render/sequence.hpp"

namespace porta::slam::render {
namespace {

namespace fs = std::filesystem;

// Small and fast: 160x48 street frames (the KITTI intrinsics scaled), 64-texel textures.
RenderOptions tiny(const std::string& out_name) {
  RenderOptions o;
  o.out_dir = (fs::path(testing::TempDir()) / ("porta_render_" + out_name)).string();
  fs::remove_all(o.out_dir);
  o.width = 160;
  o.height = 48;
  o.count = 3;
  o.texture_size = 64;
  o.threads = 1;
  return o;
}

std::string slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

bool same_pixels(const Image& a, const Image& b) {
  if (a.width() != b.width() || a.height() != b.height()) return false;
  for (int y = 0; y < a.height(); ++y)
    if (!std::equal(a.row(y), a.row(y) + a.width(), b.row(y))) return false;
  return true;
}

TEST(RenderSequence, SameOptionsGiveSameBytesWhateverTheThreadCount) {
  RenderOptions one = tiny("threads1"), two = tiny("threads2");
  one.count = two.count = 4;
  two.threads = 2;
  one.exposure_amplitude = two.exposure_amplitude = 0.3;
  write_sequence(plan_sequence(one));
  write_sequence(plan_sequence(two));
  for (const char* file : {"image_0/000000.png", "image_1/000003.png", "poses.txt", "calib.txt", "times.txt"}) {
    const std::string a = slurp(fs::path(one.out_dir) / file), b = slurp(fs::path(two.out_dir) / file);
    EXPECT_FALSE(a.empty()) << file;
    EXPECT_EQ(a, b) << file;
  }
}

TEST(RenderSequence, ARangeRendersTheSameFramesAsTheWholeRun) {
  RenderOptions all = tiny("all"), part = tiny("part");
  all.count = 4;
  part.first = 2;
  part.count = 2;
  all.motion_blur = part.motion_blur = 0.5;
  all.blur_samples = part.blur_samples = 2;
  const SequencePlan a = plan_sequence(all), b = plan_sequence(part);
  Rasterizer r;
  const StereoFrame fa = render_frame(a, 3, r), fb = render_frame(b, 1, r);
  EXPECT_TRUE(same_pixels(fa.left, fb.left));
  EXPECT_TRUE(same_pixels(fa.right, fb.right));
  // and noise differs between frames (it is keyed by frame, not constant)
  const StereoFrame f2 = render_frame(a, 2, r);
  EXPECT_FALSE(same_pixels(f2.left, fa.left));
}

TEST(RenderSequence, ClosedLoopEndsWithTheImageItStartedWith) {
  RenderOptions o = tiny("loop");
  o.builtin = BuiltinPath::street_loop;
  o.count.reset();
  o.noise_sigma = 0.0;
  const SequencePlan plan = plan_sequence(o);
  ASSERT_GT(plan.frames.size(), 400u);
  Rasterizer r;
  const StereoFrame first = render_frame(plan, 0, r), last = render_frame(plan, plan.frames.size() - 1, r);
  double total = 0;
  for (int y = 0; y < first.left.height(); ++y)
    for (int x = 0; x < first.left.width(); ++x) total += std::abs(first.left.at(x, y) - last.left.at(x, y));
  EXPECT_LT(total / (first.left.width() * first.left.height()), 0.5);  // the same place, the same world
}

TEST(RenderSequence, KittiLayout) {
  RenderOptions o = tiny("kitti");
  o.baseline_m = 0.5;
  const SequencePlan plan = plan_sequence(o);
  write_sequence(plan);
  const fs::path root(o.out_dir);
  for (int k = 0; k < 3; ++k)
    for (const char* dir : {"image_0", "image_1"}) {
      char name[16];
      std::snprintf(name, sizeof name, "%06d.png", k);
      EXPECT_TRUE(fs::is_regular_file(root / dir / name)) << dir << "/" << name;
    }
  std::ifstream calib(root / "calib.txt");
  std::string line;
  for (int p = 0; p < 4; ++p) {
    ASSERT_TRUE(std::getline(calib, line));
    std::istringstream in(line);
    std::string tag;
    double v[12];
    in >> tag;
    for (double& x : v) in >> x;
    EXPECT_EQ(tag, "P" + std::to_string(p) + ":");
    EXPECT_NEAR(v[0], plan.camera.fx, 1e-9);
    EXPECT_NEAR(v[2], plan.camera.cx, 1e-9);
    EXPECT_NEAR(v[3], p % 2 ? -plan.camera.fx * 0.5 : 0.0, 1e-9);
    EXPECT_NEAR(v[6], plan.camera.cy, 1e-9);
  }
  const Trajectory poses = read_trajectory((root / "poses.txt").string(), TrajectoryFormat::kitti, (root / "times.txt").string());
  ASSERT_EQ(poses.size(), 3u);
  EXPECT_TRUE(poses.poses[0].pose.isApprox(SE3::Identity(), 1e-12));
  EXPECT_EQ(poses.poses[0].time_s, 0.0);
  EXPECT_NEAR(poses.poses[1].time_s, 0.1, 1e-6);
  // The car drives forward: KITTI camera z.
  EXPECT_GT(poses.poses[2].pose.translation().z(), 1.0);
  EXPECT_LT(std::abs(poses.poses[2].pose.translation().y()), 0.1);
}

TEST(RenderSequence, EurocLayoutWithBodyGroundTruth) {
  RenderOptions o = tiny("euroc");
  o.builtin = BuiltinPath::room_orbit;
  o.width = 64;
  o.height = 40;
  const SequencePlan plan = plan_sequence(o);
  EXPECT_EQ(plan.layout, Layout::euroc);
  EXPECT_EQ(plan.world_kind, WorldKind::room);
  write_sequence(plan);
  const fs::path mav = fs::path(o.out_dir) / "mav0";
  std::ifstream csv(mav / "cam0" / "data.csv");
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line, "#timestamp [ns],filename");
  int rows = 0;
  while (std::getline(csv, line)) {
    const auto comma = line.find(',');
    ASSERT_NE(comma, std::string::npos);
    EXPECT_EQ(line.substr(comma + 1), line.substr(0, comma) + ".png");
    EXPECT_TRUE(fs::is_regular_file(mav / "cam1" / "data" / line.substr(comma + 1)));
    ++rows;
  }
  EXPECT_EQ(rows, 3);
  const std::string yaml = slurp(mav / "cam1" / "sensor.yaml");
  for (const char* key : {"%YAML:1.0", "T_BS:", "cols: 4", "rows: 4", "rate_hz: 20", "resolution: [64, 40]",
                          "camera_model: pinhole", "distortion_model: radial-tangential",
                          "distortion_coefficients: [0.0, 0.0, 0.0, 0.0]"})
    EXPECT_NE(yaml.find(key), std::string::npos) << key;
  // Ground truth: body poses; camera = body * T_BS reproduces the rendered camera.
  const Trajectory gt = read_trajectory((mav / "state_groundtruth_estimate0" / "data.csv").string(), TrajectoryFormat::euroc);
  ASSERT_EQ(gt.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k)
    EXPECT_TRUE((gt.poses[k].pose * plan.T_body_cam0).isApprox(plan.frames[k].input_cam, 1e-6)) << k;
}

TEST(RenderSequence, BodyPosesGetTheEurocCameraTransform) {
  const fs::path file = fs::path(testing::TempDir()) / "porta_render_body.csv";
  {
    std::ofstream out(file);
    out << "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z []\n";
    for (int k = 0; k < 5; ++k) out << 1000000000LL + k * 50000000LL << "," << 0.1 * k << ",0,1.2,1,0,0,0\n";
  }
  RenderOptions o = tiny("body");
  o.trajectory_path = file.string();
  o.count.reset();
  const SequencePlan plan = plan_sequence(o);
  EXPECT_EQ(plan.world_kind, WorldKind::room);
  ASSERT_EQ(plan.frames.size(), 5u);
  EXPECT_TRUE(plan.frames[0].input_cam.isApprox(plan.frames[0].input_body * euroc_T_body_cam0(), 1e-12));
  EXPECT_EQ(euroc_ns(plan.frames[1].time_s), 1050000000LL);
}

TEST(RenderSequence, BadOptionsAreErrorsNamingTheProblem) {
  const auto message = [](RenderOptions o) -> std::string {
    try {
      plan_sequence(o);
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  };
  RenderOptions o = tiny("bad");
  o.first = 5000;
  EXPECT_NE(message(o).find("outside the trajectory"), std::string::npos) << message(o);
  o = tiny("bad");
  o.baseline_m = -1;
  EXPECT_NE(message(o).find("baseline"), std::string::npos) << message(o);
  o = tiny("bad");
  o.cx = 5000;
  EXPECT_NE(message(o).find("cx 5000 is outside the image"), std::string::npos) << message(o);
  o = tiny("bad");
  o.supersample = 9;
  EXPECT_NE(message(o).find("supersample"), std::string::npos) << message(o);
  o = tiny("bad");
  o.trajectory_path = "/nonexistent/poses.txt";
  EXPECT_NE(message(o).find("/nonexistent/poses.txt"), std::string::npos) << message(o);
  o = tiny("bad");
  o.out_dir = "/proc/porta_render_not_writable";
  EXPECT_THROW(write_sequence(plan_sequence(o)), RenderError);
}

}  // namespace
}  // namespace porta::slam::render
#endif
