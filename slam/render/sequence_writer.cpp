// Writing a planned sequence to disk (sequence.hpp) in the KITTI odometry layout
//   image_0/NNNNNN.png, image_1/NNNNNN.png, calib.txt (P0..P3), times.txt, poses.txt
// or the EuRoC ASL layout
//   mav0/cam{0,1}/data.csv, data/<ns>.png, sensor.yaml; mav0/state_groundtruth_estimate0/data.csv
// with frames rendered in parallel (each worker owns a Rasterizer; a frame's bytes do not depend on
// which worker renders it).
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <mutex>
#include <sstream>
#include <thread>

#include "imageio/png_file.hpp"
#include "porta/slam/atomic_file.hpp"
#include "porta/slam/render/sequence.hpp"

namespace porta::slam::render {

namespace fs = std::filesystem;

namespace {

std::string printf_string(const char* format, double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, v);
  return buffer;
}

/// A text file is composed in memory, then written whole or not at all by finish().
std::ostringstream open_for_writing(const fs::path&) { return std::ostringstream(); }

void finish(std::ostringstream& out, const fs::path& path) {
  try {
    write_file_atomically(path.string(), out.str());
  } catch (const AtomicWriteError& e) {
    throw RenderError(e.what());
  }
}

void make_folder(const fs::path& path) {
  std::error_code ec;
  fs::create_directories(path, ec);
  if (ec || !fs::is_directory(path))
    throw RenderError("cannot create output folder " + path.string() + ": " + (ec ? ec.message() : "a file is in the way"));
}

void write_kitti_calib(const SequencePlan& plan, const fs::path& path) {
  const StereoCamera& c = plan.camera;
  std::ostringstream out = open_for_writing(path);
  for (int k = 0; k < 4; ++k) {
    const double tx = (k % 2 == 1) ? -c.fx * c.baseline_m : 0.0;
    const double row[12] = {c.fx, 0, c.cx, tx, 0, c.fy, c.cy, 0, 0, 0, 1, 0};
    out << 'P' << k << ':';
    for (double v : row) out << ' ' << printf_string("%.12e", v);
    out << '\n';
  }
  finish(out, path);
}

void write_euroc_sensor(const SequencePlan& plan, const fs::path& path, int camera) {
  const StereoCamera& c = plan.camera;
  const SE3 T = plan.T_body_cam0 * SE3(Eigen::Translation3d(camera * c.baseline_m, 0, 0));
  const Eigen::Matrix4d m = T.matrix();
  std::ostringstream out = open_for_writing(path);
  out << "%YAML:1.0\n# General sensor definitions.\nsensor_type: camera\ncomment: PortaSLAM rendered cam" << camera
      << " (rectified pinhole, no distortion; cam1 is cam0 moved " << c.baseline_m << " m along its x axis)\n\n"
      << "# Sensor extrinsics wrt. the body-frame.\nT_BS:\n  cols: 4\n  rows: 4\n  data: [";
  for (int r = 0; r < 4; ++r) {
    for (int col = 0; col < 4; ++col) {
      out << printf_string("%.12g", m(r, col) == 0.0 ? 0.0 : m(r, col));
      if (r < 3 || col < 3) out << ", ";
    }
    if (r < 3) out << "\n         ";
  }
  out << "]\n\n# Camera specific definitions.\nrate_hz: " << std::lround(plan.rate_hz) << "\nresolution: [" << c.width << ", "
      << c.height << "]\ncamera_model: pinhole\nintrinsics: [" << printf_string("%.12g", c.fx) << ", "
      << printf_string("%.12g", c.fy) << ", " << printf_string("%.12g", c.cx) << ", " << printf_string("%.12g", c.cy)
      << "] #fu, fv, cu, cv\ndistortion_model: radial-tangential\ndistortion_coefficients: [0.0, 0.0, 0.0, 0.0]\n";
  finish(out, path);
}

}  // namespace

long long euroc_ns(double time_s) { return std::llround(time_s * 1e9); }

std::string image_path(const SequencePlan& plan, std::size_t k, int camera) {
  const fs::path root(plan.options.out_dir);
  if (plan.layout == Layout::kitti) {
    char name[32];
    std::snprintf(name, sizeof name, "%06zu.png", k);
    return (root / (camera == 0 ? "image_0" : "image_1") / name).string();
  }
  return (root / "mav0" / (camera == 0 ? "cam0" : "cam1") / "data" /
          (std::to_string(euroc_ns(plan.frames.at(k).time_s)) + ".png"))
      .string();
}

void write_layout_files(const SequencePlan& plan) {
  const fs::path root(plan.options.out_dir);
  make_folder(root);
  if (plan.layout == Layout::kitti) {
    make_folder(root / "image_0");
    make_folder(root / "image_1");
    write_kitti_calib(plan, root / "calib.txt");
    Trajectory relative;
    const SE3 first_inverse = plan.frames.front().input_cam.inverse();
    for (const auto& f : plan.frames) relative.poses.push_back({f.time_s - plan.frames.front().time_s, first_inverse * f.input_cam});
    relative.poses.front().pose = SE3::Identity();  // exactly, not up to rounding
    const fs::path times = root / "times.txt";
    std::ostringstream out = open_for_writing(times);
    for (const auto& p : relative.poses) out << printf_string("%e", p.time_s) << '\n';
    finish(out, times);
    try {
      write_trajectory((root / "poses.txt").string(), relative, TrajectoryFormat::kitti);
    } catch (const TrajectoryError& e) {
      throw RenderError(e.what());
    }
    return;
  }
  const fs::path mav = root / "mav0";
  for (int camera = 0; camera < 2; ++camera) {
    const fs::path dir = mav / (camera == 0 ? "cam0" : "cam1");
    make_folder(dir / "data");
    write_euroc_sensor(plan, dir / "sensor.yaml", camera);
    const fs::path csv = dir / "data.csv";
    std::ostringstream out = open_for_writing(csv);
    out << "#timestamp [ns],filename\n";
    for (const auto& f : plan.frames) out << euroc_ns(f.time_s) << ',' << euroc_ns(f.time_s) << ".png\n";
    finish(out, csv);
  }
  {
    const fs::path body = mav / "body.yaml";
    std::ostringstream out = open_for_writing(body);
    out << "%YAML:1.0\ncomment: PortaSLAM rendered sequence (" << plan.source << ")\n";
    finish(out, body);
  }
  make_folder(mav / "state_groundtruth_estimate0");
  const fs::path gt = mav / "state_groundtruth_estimate0" / "data.csv";
  std::ostringstream out = open_for_writing(gt);
  out << "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z []\n";
  for (const auto& f : plan.frames) {
    const Eigen::Quaterniond q(f.input_body.rotation());
    const Eigen::Vector3d p = f.input_body.translation();
    out << euroc_ns(f.time_s);
    for (double v : {p.x(), p.y(), p.z(), q.w(), q.x(), q.y(), q.z()}) out << ',' << printf_string("%.9f", v);
    out << '\n';
  }
  finish(out, gt);
}

WriteReport write_sequence(const SequencePlan& plan, const std::function<void(std::size_t, std::size_t, double)>& progress) {
  const auto start = std::chrono::steady_clock::now();
  write_layout_files(plan);
  const std::size_t total = plan.frames.size();
  const int workers = static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(std::max(1, plan.options.threads)), total));
  std::atomic<std::size_t> next{0};
  std::atomic<bool> failed{false};
  std::mutex mutex;
  std::condition_variable changed;
  std::size_t done = 0;
  std::exception_ptr error;
  auto work = [&] {
    Rasterizer rasterizer;
    for (;;) {
      const std::size_t k = next.fetch_add(1);
      if (k >= total || failed.load()) break;
      try {
        const StereoFrame frame = render_frame(plan, k, rasterizer);
        for (int camera = 0; camera < 2; ++camera) {
          const Image& image = camera == 0 ? frame.left : frame.right;
          const std::string path = image_path(plan, k, camera);
          try {
            io::write_png_gray(path, image.width(), image.height(), image.data(), static_cast<std::size_t>(image.pitch_bytes()));
          } catch (const io::PngError& e) {
            throw RenderError("cannot write " + path + ": " + e.what());
          }
        }
      } catch (...) {
        std::lock_guard lock(mutex);
        if (!error) error = std::current_exception();
        failed = true;
      }
      {
        std::lock_guard lock(mutex);
        ++done;
      }
      changed.notify_all();
    }
  };
  std::vector<std::thread> threads;
  for (int t = 0; t < workers; ++t) threads.emplace_back(work);
  auto seconds = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  double last_report = 0.0;
  {
    std::unique_lock lock(mutex);
    while (done < total && !failed) {
      changed.wait_for(lock, std::chrono::milliseconds(500));
      if (progress && seconds() - last_report >= 2.0 && done < total) {
        last_report = seconds();
        const std::size_t d = done;
        lock.unlock();
        progress(d, total, last_report);
        lock.lock();
      }
    }
  }
  for (auto& t : threads) t.join();
  if (error) std::rethrow_exception(error);
  WriteReport report{total, seconds()};
  if (progress) progress(total, total, report.seconds);
  return report;
}

}  // namespace porta::slam::render
