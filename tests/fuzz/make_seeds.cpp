// Writes the fuzz targets' seed corpora (tests/fuzz/README in docs/RELIABILITY.md) into OUT/<target>/,
// every seed made by the project itself: PNG files from our writer (gray, RGB, 16-bit-like sizes),
// the shipped settings files, trajectories from our writer in every format, KITTI calib/times and
// EuRoC sensor.yaml/data.csv for the 64x48 scaffolds of the targets, and a map file saved from the
// synthetic mapping scene of the map-file tests.
//   usage: porta_fuzz_make_seeds OUT SETTINGS_DIR
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "../slam/map_file_scene.hpp"
#include "imageio/png_file.hpp"
#include "porta/slam/map_file.hpp"
#include "porta/slam/trajectory_io.hpp"

namespace {

namespace fs = std::filesystem;
using namespace porta;

void write_text(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary | std::ios::trunc) << text;
}

std::string sensor_yaml(double baseline_x) {
  return "%YAML:1.0\nsensor_type: camera\nT_BS:\n  cols: 4\n  rows: 4\n  data: [1.0, 0.0, 0.0, " +
         std::to_string(baseline_x) +
         ", 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]\nrate_hz: 20\nresolution: [64, 48]\n"
         "camera_model: pinhole\nintrinsics: [40.0, 40.0, 32.0, 24.0]\ndistortion_model: radial-tangential\n"
         "distortion_coefficients: [-0.28, 0.07, -0.0001, 0.00003]\n";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s OUT SETTINGS_DIR\n", argv[0]);
    return 2;
  }
  const fs::path out(argv[1]);
  fs::remove_all(out);

  // PNG: gray and colour images from our writer: tiny ones, and a textured gray one.
  fs::create_directories(out / "png");
  std::vector<std::uint8_t> gray(32 * 24), rgb(16 * 8 * 3);
  for (std::size_t i = 0; i < gray.size(); ++i) gray[i] = static_cast<std::uint8_t>(i * 7);
  for (std::size_t i = 0; i < rgb.size(); ++i) rgb[i] = static_cast<std::uint8_t>(i * 13);
  io::write_png_gray((out / "png" / "gray_32x24.png").string(), 32, 24, gray.data(), 32);
  io::write_png_gray((out / "png" / "gray_1x1.png").string(), 1, 1, gray.data(), 1, 9);
  io::write_png_rgb((out / "png" / "rgb_16x8.png").string(), 16, 8, rgb.data(), 16 * 3);
  // Above 16 KiB of rows libpng writes a 32-KiB zlib window: the case the fast gray reader takes.
  std::vector<std::uint8_t> textured(160 * 120);
  for (std::size_t i = 0; i < textured.size(); ++i)
    textured[i] = static_cast<std::uint8_t>(i % 160 + (i / 160) * 3 + ((i * 2654435761u) >> 27 & 15));
  io::write_png_gray((out / "png" / "gray_160x120.png").string(), 160, 120, textured.data(), 160);

  // Settings: the shipped files and the smallest complete one.
  fs::create_directories(out / "settings");
  for (const auto& e : fs::directory_iterator(argv[2]))
    if (e.path().extension() == ".yaml") fs::copy_file(e.path(), out / "settings" / e.path().filename());
  write_text(out / "settings" / "minimal.yaml",
             "%YAML:1.0\nCamera.fx: 500.0\nCamera.fy: 500.0\nCamera.cx: 320.0\nCamera.cy: 240.0\nCamera.bf: 60.0\n"
             "Camera.width: 640\nCamera.height: 480\nORBextractor.nLevels: 8\nORBextractor.scaleFactor: 1.2\n");

  // Trajectories: a short helix in each format; the first byte selects the reader (fuzz_trajectory.cpp).
  slam::Trajectory helix;
  helix.has_times = true;
  for (int i = 0; i < 6; ++i) {
    slam::StampedPose p;
    p.time_s = 1403715273.262142976 + 0.05 * i;
    p.pose.linear() = Eigen::AngleAxisd(0.1 * i, Eigen::Vector3d(0.2, 1.0, 0.1).normalized()).toRotationMatrix();
    p.pose.translation() << std::cos(0.3 * i), 0.1 * i, std::sin(0.3 * i);
    helix.poses.push_back(p);
  }
  const fs::path scratch = out / "scratch";
  fs::create_directories(scratch);
  const auto seed_of = [&](char mode, slam::TrajectoryFormat format, const std::string& name, const std::string& tail) {
    const fs::path file = scratch / name;
    slam::write_trajectory(file.string(), helix, format);
    std::ifstream in(file, std::ios::binary);
    const std::string body((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    write_text(out / "trajectory" / name, std::string(1, mode) + body + tail);
  };
  seed_of('\0', slam::TrajectoryFormat::tum, "detect_tum.txt", "");
  seed_of('\1', slam::TrajectoryFormat::tum, "tum.txt", "");
  seed_of('\2', slam::TrajectoryFormat::kitti, "kitti.txt", "");
  seed_of('\3', slam::TrajectoryFormat::euroc, "euroc.csv", "");
  seed_of('\4', slam::TrajectoryFormat::kitti, "kitti_times.txt", "\f0.0\n0.1\n0.2\n0.3\n0.4\n0.5\n");

  // KITTI calib.txt (+ times.txt) for the 64x48 scaffold: fx 40, baseline 0.2 m.
  const std::string calib =
      "P0: 40 0 32 0 0 40 24 0 0 0 1 0\nP1: 40 0 32 -8 0 40 24 0 0 0 1 0\nP2: 40 0 32 0 0 40 24 0 0 0 1 0\n"
      "P3: 40 0 32 -8 0 40 24 0 0 0 1 0\n";
  write_text(out / "kitti" / "calib_only.txt", calib);
  write_text(out / "kitti" / "calib_and_times.txt", calib + "\f0.000000e+00\n1.036602e-01\n");

  // EuRoC: cam0 and cam1 sensor.yaml (10 cm apart), with and without a data.csv.
  write_text(out / "euroc" / "sensors.yaml", sensor_yaml(0.0) + "\f" + sensor_yaml(0.1));
  write_text(out / "euroc" / "sensors_and_csv.yaml", sensor_yaml(0.0) + "\f" + sensor_yaml(0.1) +
                                                         "\f#timestamp [ns],filename\n1403715273262142976,"
                                                         "1403715273262142976.png\n1403715273312143104,"
                                                         "1403715273312143104.png\n");

  // A map file from a small synthetic mapping scene (every kind of field, a few KB, so that
  // libFuzzer's inputs stay small and fast), with and without the checksum fix-up flag.
  {
    slam::mapping_test::SceneSpec spec;
    spec.near_points = 16;
    spec.far_points = 8;
    spec.keyframes = 3;
    spec.clutter = 4;
    const auto map = slam::mapping_test::make_scene_map(spec);
    const fs::path file = scratch / "scene.pmap";
    slam::save_map(file.string(), *map, slam::mapping_test::test_settings());
    std::ifstream in(file, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    write_text(out / "map" / "scene_checked.pmap", std::string(1, '\0') + bytes);
    write_text(out / "map" / "scene_fixed_crc.pmap", std::string(1, '\1') + bytes);
    slam::save_map(file.string(), slam::Map(), slam::mapping_test::test_settings());
    std::ifstream empty_in(file, std::ios::binary);
    const std::string empty((std::istreambuf_iterator<char>(empty_in)), std::istreambuf_iterator<char>());
    write_text(out / "map" / "empty_fixed_crc.pmap", std::string(1, '\1') + empty);
  }
  fs::remove_all(scratch);
  std::printf("fuzz seeds written to %s\n", out.string().c_str());
  return 0;
}
