// `portaslam bench`: the frontend throughput matrix (resolutions x pyramid levels x modes, per
// backend), with OpenCV's cv::ORB on the CPU timed on the same images in the same run as a peer.
// A build without OpenCV C++ has no peer and says so; bench/orb_peer.py times cv2.ORB from Python.
// One timed frame = the wall time of one Frontend::detect / detect_stereo call, which uploads the
// image, runs every kernel, and downloads keypoints, descriptors and matches (a download waits
// for the device), so it is the whole cost a SLAM system pays per frame.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "bench_inputs.hpp"
#include "bench_kernels.hpp"
#include "bench_options.hpp"
#include "cli_args.hpp"
#include "porta/json_text.hpp"
#include "output_paths.hpp"
#include "porta/frontend.hpp"
#include "porta/registry.hpp"
#include "porta/slam/atomic_file.hpp"

#if PORTA_APPS_HAVE_OPENCV
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#endif

namespace porta::app {

namespace {

const char* const kPeerName = "opencv-orb";
constexpr bool kPeerBuilt = PORTA_APPS_HAVE_OPENCV;
const char* const kPeerNotBuilt = "peer not built (no OpenCV C++)";
const char* const kPythonPeerHint =
    "bench/orb_peer.py --ours FILE.json times cv2.ORB on the same images and prints the ratios";

using Clock = std::chrono::steady_clock;

double elapsed_us(Clock::time_point since) {
  return std::chrono::duration<double, std::micro>(Clock::now() - since).count();
}

// ---- What one row of the matrix holds ------------------------------------------------------------

struct FrameResult {
  double us = 0.0;
  double submit_us = 0.0;   // host time inside submit: copies and enqueueing
  double collect_us = 0.0;  // host time inside collect: waiting for the frame, then copying out
  double keypoints = 0.0;  // per image (mean of left and right for a pair)
  int matches = 0;
};

// Linear interpolation between closest ranks of a sorted sample (numpy's default); 0 when empty.
double percentile_of(const std::vector<double>& sorted, double p) {
  if (sorted.empty()) return 0.0;
  const double rank = p / 100.0 * static_cast<double>(sorted.size() - 1);
  const auto lo = static_cast<std::size_t>(rank);
  const std::size_t hi = std::min(lo + 1, sorted.size() - 1);
  return sorted[lo] + (rank - static_cast<double>(lo)) * (sorted[hi] - sorted[lo]);
}
double median_of(const std::vector<double>& sorted) { return percentile_of(sorted, 50); }

struct Row {
  Row(std::string backend_name, Resolution cell_size, int cell_levels, BenchMode cell_mode, int frames_in_flight = 1,
      bool pinned = false)
      : backend(std::move(backend_name)), size(cell_size), levels(cell_levels), mode(cell_mode),
        in_flight(frames_in_flight), pinned_input(pinned) {}

  std::string backend;  // a backend's name, or kPeerName
  Resolution size;
  int levels = 0;
  BenchMode mode = BenchMode::detect;
  int in_flight = 1;       // > 1: throughput with that many frames in flight
  bool pinned_input = false;  // images in pinned InputImages, no host copy per frame
  std::vector<double> us;  // per timed frame, sorted
  std::vector<double> submit_us, collect_us;  // per timed frame, sorted (ours only)
  std::vector<KernelTime> kernels;  // --profile-kernels: device time per kernel over the timed frames
  double mean_keypoints = 0.0;
  double mean_matches = 0.0;
  double speedup = 0.0;  // ours: peer median / our median; 0 = no peer
  int peer_nfeatures = 0;
  std::string error;  // why this row has no numbers (a backend that failed the cell), else empty

  double percentile(double p) const { return percentile_of(us, p); }
  double median() const { return percentile(50); }
  /// "cuda", "cuda/4" with 4 frames in flight, "cuda/4+pin" with pinned input images.
  std::string label() const {
    // Appended piece by piece: GCC 12 for aarch64 warns falsely (-Wrestrict, GCC bug 105651) on
    // `"/" + std::to_string(n)`, and warnings are errors in the cross build too.
    std::string text = backend;
    if (in_flight > 1) text += '/' + std::to_string(in_flight);
    if (pinned_input) text += "+pin";
    return text;
  }
  double frames_per_s() const { return 1e6 / median(); }
  /// The mean; with frames in flight, the timed frames' total time over their number: the
  /// throughput also when results come in bursts (a backend that runs several frames as one batch).
  double mean() const {
    double sum = 0.0;
    for (const double v : us) sum += v;
    return us.empty() ? 0.0 : sum / static_cast<double>(us.size());
  }
};

template <typename TimedCall>  // FrameResult(std::size_t frame)
void measure(Row& row, int warmup, int frames, TimedCall&& call, Backend* profiled = nullptr) {
  for (int i = 0; i < warmup; ++i) call(static_cast<std::size_t>(i));
  if (profiled != nullptr) profiled->kernel_times(true);  // from the first timed frame on
  double keypoints = 0.0, matches = 0.0;
  for (int i = 0; i < frames; ++i) {
    const FrameResult r = call(static_cast<std::size_t>(warmup + i));
    row.us.push_back(r.us);
    row.submit_us.push_back(r.submit_us);
    row.collect_us.push_back(r.collect_us);
    keypoints += r.keypoints;
    matches += r.matches;
  }
  if (profiled != nullptr) row.kernels = profiled->kernel_times(true);
  std::sort(row.us.begin(), row.us.end());
  std::sort(row.submit_us.begin(), row.submit_us.end());
  std::sort(row.collect_us.begin(), row.collect_us.end());
  row.mean_keypoints = keypoints / frames;
  row.mean_matches = matches / frames;
}

FrameResult features_of(const Features& f) {
  FrameResult r;
  r.keypoints = static_cast<double>(f.keypoints.size());
  return r;
}
FrameResult features_of(const StereoFeatures& f) {
  FrameResult r;
  r.keypoints = static_cast<double>(f.left.keypoints.size() + f.right.keypoints.size()) / 2.0;
  r.matches = f.num_matches();
  return r;
}

void time_ours(Row& row, Backend& backend, const BenchFrames& in, const BenchOptions& options) {
  FrontendSettings settings;
  settings.levels = row.levels;
  FrontendOptions frontend_options;
  frontend_options.describe = row.mode != BenchMode::detect;
  frontend_options.in_flight = row.in_flight;
  Frontend frontend(backend, settings, row.size.width, row.size.height, frontend_options);
  const bool stereo = row.mode == BenchMode::stereo;
  Backend* const profiled = options.profile_kernels ? &backend : nullptr;
  // Pinned input: every distinct input image in an InputImage of its own, filled before timing (as
  // a camera's DMA would fill them); frame i reads image i % count, the same images as the copy rows.
  // The device only reads them, so frames in flight may share one.
  std::vector<InputImage> pinned_left, pinned_right;
  if (row.pinned_input) {
    for (const Image& image : in.left) {
      pinned_left.push_back(frontend.make_input_image());
      pinned_left.back().assign(image.view());
    }
    for (const Image& image : in.right) {
      if (!stereo) break;
      pinned_right.push_back(frontend.make_input_image());
      pinned_right.back().assign(image.view());
    }
  }
  auto submit = [&](std::size_t frame) {  // returns the µs it took
    const Image& left = in.left[frame % in.left.size()];
    const Clock::time_point t0 = Clock::now();
    if (row.pinned_input && stereo)
      frontend.submit_stereo(pinned_left[frame % in.left.size()], pinned_right[frame % in.right.size()]);
    else if (row.pinned_input)
      frontend.submit(pinned_left[frame % in.left.size()]);
    else if (stereo)
      frontend.submit_stereo(left.view(), in.right[frame % in.right.size()].view());
    else
      frontend.submit(left.view());
    return elapsed_us(t0);
  };
  auto collect = [&] {
    const Clock::time_point t0 = Clock::now();
    FrameResult r = stereo ? features_of(frontend.collect_stereo()) : features_of(frontend.collect());
    r.collect_us = elapsed_us(t0);
    return r;
  };

  if (row.in_flight == 1) {  // latency: one call, submit to results
    measure(row, options.warmup, options.frames, [&](std::size_t frame) {
      const Clock::time_point t0 = Clock::now();
      const double submit_us = submit(frame);
      FrameResult r = collect();
      r.us = elapsed_us(t0);
      r.submit_us = submit_us;
      return r;
    }, profiled);
    return;
  }
  // Throughput: N frames always in flight; a frame's time is the interval from the previous frame's
  // results to its own, in which the host also submits one frame. Frames past the timed ones keep
  // the pipeline full to the end and are collected untimed.
  std::size_t submitted = 0;
  while (static_cast<int>(submitted) < row.in_flight) submit(submitted++);
  Clock::time_point last = Clock::now();
  measure(row, options.warmup, options.frames, [&](std::size_t) {
    FrameResult r = collect();
    r.submit_us = submit(submitted++);
    const Clock::time_point now = Clock::now();
    r.us = std::chrono::duration<double, std::micro>(now - last).count();
    last = now;
    return r;
  }, profiled);
  while (frontend.pending() > 0) collect();
}

#if PORTA_APPS_HAVE_OPENCV

// A cv::Mat header on an image's pixels (no copy).
cv::Mat mat_of(const Image& image) {
  return cv::Mat(image.height(), image.width(), CV_8U, const_cast<std::uint8_t*>(image.data()),
                 static_cast<std::size_t>(image.pitch_bytes()));
}

// cv::ORB with nfeatures and `levels`, our default scale (1.2) and FAST threshold (20), OpenCV's
// other defaults (edge threshold 31, Harris score, patch 31). stereo: both images + brute-force Hamming
// matching with cross-check, which has no row or disparity constraint: not our stereo matching, only the
// closest cheap peer.
void time_peer(Row& row, const BenchFrames& in, const BenchOptions& options) {
  const FrontendSettings ours;
  const cv::Ptr<cv::ORB> orb =
      cv::ORB::create(row.peer_nfeatures, static_cast<float>(ours.scale_factor), row.levels, 31, 0, 2,
                      cv::ORB::HARRIS_SCORE, 31, ours.fast_threshold);
  cv::BFMatcher matcher(cv::NORM_HAMMING, true);
  measure(row, options.warmup, options.frames, [&](std::size_t frame) {
    const cv::Mat left = mat_of(in.left[frame % in.left.size()]);
    const cv::Mat right = row.mode == BenchMode::stereo ? mat_of(in.right[frame % in.right.size()]) : cv::Mat();
    std::vector<cv::KeyPoint> kl, kr;
    cv::Mat dl, dr;
    std::vector<cv::DMatch> matches;
    FrameResult r;
    const Clock::time_point t0 = Clock::now();
    if (row.mode == BenchMode::detect) {
      orb->detect(left, kl);
    } else {
      orb->detectAndCompute(left, cv::noArray(), kl, dl);
      if (row.mode == BenchMode::stereo) {
        orb->detectAndCompute(right, cv::noArray(), kr, dr);
        if (!dl.empty() && !dr.empty()) matcher.match(dl, dr, matches);
      }
    }
    r.us = elapsed_us(t0);
    r.keypoints = row.mode == BenchMode::stereo ? static_cast<double>(kl.size() + kr.size()) / 2.0
                                                : static_cast<double>(kl.size());
    r.matches = static_cast<int>(matches.size());
    return r;
  });
}

#else

void time_peer(Row&, const BenchFrames&, const BenchOptions&) {}  // never called: kPeerBuilt is false

#endif

// ---- The machine, the date, the commit -----------------------------------------------------------

std::string first_line_of(const std::string& command) {
  std::string out;
  if (FILE* pipe = popen(command.c_str(), "r")) {
    char buffer[256];
    if (std::fgets(buffer, sizeof buffer, pipe)) out = buffer;
    pclose(pipe);
  }
  while (!out.empty() && (out.back() == '\n' || out.back() == '\r')) out.pop_back();
  return out;
}

// The value of the first "key : value" line of a /proc file whose key starts with `key`.
std::string proc_value(const char* file, const std::string& key) {
  std::ifstream in(file);
  for (std::string line; std::getline(in, line);) {
    const auto colon = line.find(':');
    if (line.rfind(key, 0) == 0 && colon != std::string::npos) {
      const auto start = line.find_first_not_of(" \t", colon + 1);
      return start == std::string::npos ? "" : line.substr(start);
    }
  }
  return "";
}

struct Machine {
  std::string cpu_model;
  unsigned hardware_threads = 0;
  double memory_gib = 0.0;
  std::string date;    // UTC, ISO 8601
  std::string commit;  // short hash, or "unknown"
  bool worktree_modified = false;
  int opencv_threads = 0;  // cv::getNumThreads(); 0 without OpenCV
};

Machine describe_machine() {
  Machine m;
  m.cpu_model = proc_value("/proc/cpuinfo", "model name");
  if (m.cpu_model.empty()) m.cpu_model = "unknown";
  m.hardware_threads = std::thread::hardware_concurrency();
  m.memory_gib = std::atof(proc_value("/proc/meminfo", "MemTotal").c_str()) / (1024.0 * 1024.0);  // kB
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char date[32];
  std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", &utc);
  m.date = date;
  // The checkout we run in, else the one this binary was built from.
  for (const std::string& git : {std::string("git"), "git -C '" + std::string(PORTA_SOURCE_DIR) + "'"}) {
    m.commit = first_line_of(git + " rev-parse --short HEAD 2>/dev/null");
    if (m.commit.empty()) continue;
    m.worktree_modified =
        !first_line_of(git + " status --porcelain --untracked-files=no 2>/dev/null").empty();
    break;
  }
  if (m.commit.empty()) m.commit = "unknown";
#if PORTA_APPS_HAVE_OPENCV
  m.opencv_threads = cv::getNumThreads();
#endif
  return m;
}

// ---- Output --------------------------------------------------------------------------------------

struct Report {
  BenchOptions options;
  Machine machine;
  std::vector<std::pair<std::string, std::string>> devices;  // backend, device_name()
  std::vector<std::pair<std::string, std::string>> inputs;   // resolution, source in words
  std::string data_folder;
  std::vector<Row> rows;
  double seconds = 0.0;
};

const char* const kTimingNote =
    "wall time of one Frontend submit + collect (detect / detect_stereo): upload, every kernel, "
    "synchronisation, download of keypoints, descriptors and matches; rows BACKEND/N: throughput with N "
    "frames in flight, the interval between consecutive frames' results (each still uploaded, "
    "processed and downloaded); rows +pin: the same images already lie in pinned input images (filled "
    "before timing, as a camera writes its frames), so no host copy per frame; the upload is the device's "
    "own transfer";
const char* const kPeerNote =
    "cv::ORB on the CPU, nfeatures = our mean keypoints per image in the same cell, scale 1.2, FAST "
    "threshold 20, Harris score, patch 31; stereo = detectAndCompute on both images + "
    "cv::BFMatcher(NORM_HAMMING, crossCheck): no row or disparity constraint, not the same stereo "
    "matching as ours, the closest cheap peer";

void print_header(const Report& r) {
  const Machine& m = r.machine;
  std::printf("portaslam bench: per cell %d timed frame%s after %d warm-up frame%s\n", r.options.frames,
              r.options.frames == 1 ? "" : "s", r.options.warmup, r.options.warmup == 1 ? "" : "s");
  std::printf("machine   %s, %u hardware threads, %.1f GiB; %s, commit %s%s\n", m.cpu_model.c_str(),
              m.hardware_threads, m.memory_gib, m.date.c_str(), m.commit.c_str(),
              m.worktree_modified ? " (with local changes)" : "");
  for (const auto& [name, device] : r.devices)
    std::printf("backend   %s: %s\n", name.c_str(), device.c_str());
#if PORTA_APPS_HAVE_OPENCV
  if (r.options.peer)
    std::printf("peer      %s: OpenCV %s on %d threads; %s\n", kPeerName, CV_VERSION, m.opencv_threads,
                kPeerNote);
#else
  if (r.options.peer) std::printf("peer      %s: %s; %s\n", kPeerName, kPeerNotBuilt, kPythonPeerHint);
#endif
  std::printf("timing    %s\n", kTimingNote);
  std::printf("data      %s\n", r.data_folder.c_str());
  for (const auto& [size, source] : r.inputs)
    std::printf("input     %-9s %s\n", size.c_str(), source.c_str());
}

void print_table(const Report& r) {
  std::printf("\n%-10s %-10s %6s  %-7s %10s %10s %10s %10s %9s %9s %8s %8s\n", "backend", "resolution", "levels",
              "mode", "median_us", "p10_us", "p90_us", "mean_us", "frames/s", "keypoints", "matches", "speedup");
  for (const Row& row : r.rows) {
    if (!row.error.empty()) {
      std::printf("%-10s %-10s %6d  %-7s %s\n", row.label().c_str(), row.size.text().c_str(), row.levels,
                  mode_name(row.mode), row.error.c_str());
      continue;
    }
    char matches[16] = "-", speedup[16] = "-";
    if (row.mode == BenchMode::stereo) std::snprintf(matches, sizeof matches, "%.0f", row.mean_matches);
    if (row.speedup > 0) std::snprintf(speedup, sizeof speedup, "%.2fx", row.speedup);
    std::printf("%-10s %-10s %6d  %-7s %10.0f %10.0f %10.0f %10.0f %9.1f %9.0f %8s %8s\n", row.label().c_str(),
                row.size.text().c_str(), row.levels, mode_name(row.mode), row.median(), row.percentile(10),
                row.percentile(90), row.mean(), row.frames_per_s(), row.mean_keypoints, matches, speedup);
  }
  std::printf(
      "\nframes/s = 1e6 / median (stereo: pairs/s); mean_us: with frames in flight, the timed frames' total "
      "time over their number (the throughput where results come in bursts); keypoints = mean per image; "
      "matches = mean stereo matches per pair\n");
  if (r.options.peer && kPeerBuilt)
    std::printf("speedup = %s median / our median, measured in this run (> 1: ours is faster)\n", kPeerName);
  else if (r.options.peer)
    std::printf("speedup: none, %s; %s\n", kPeerNotBuilt, kPythonPeerHint);
  std::printf("%.1f s in all\n", r.seconds);
}


void write_json(std::ostream& out, const Report& r) {
  const Machine& m = r.machine;
  const BenchOptions& o = r.options;
  const FrontendSettings s;
  out << "{\n  \"tool\": \"portaslam bench\",\n  \"date\": " << json_string(m.date)
      << ",\n  \"commit\": " << json_string(m.commit)
      << ",\n  \"worktree_modified\": " << (m.worktree_modified ? "true" : "false")
      << ",\n  \"seconds\": " << r.seconds << ",\n";
  out << "  \"machine\": {\"cpu_model\": " << json_string(m.cpu_model)
      << ", \"hardware_threads\": " << m.hardware_threads << ", \"memory_gib\": " << m.memory_gib << "},\n";
  out << "  \"backends\": [";
  for (std::size_t i = 0; i < r.devices.size(); ++i)
    out << (i ? ", " : "") << "{\"name\": " << json_string(r.devices[i].first)
        << ", \"device\": " << json_string(r.devices[i].second) << "}";
  out << "],\n  \"peer\": ";
#if PORTA_APPS_HAVE_OPENCV
  if (o.peer)
    out << "{\"name\": \"" << kPeerName << "\", \"opencv_version\": \"" << CV_VERSION
        << "\", \"opencv_threads\": " << m.opencv_threads << ", \"what\": " << json_string(kPeerNote) << "}";
#else
  if (o.peer)
    out << "{\"name\": \"" << kPeerName << "\", \"built\": false, \"error\": " << json_string(kPeerNotBuilt)
        << ", \"what\": " << json_string(kPythonPeerHint) << "}";
#endif
  else
    out << "null";
  out << ",\n  \"settings\": {\"frames\": " << o.frames << ", \"warmup\": " << o.warmup
      << ", \"threads\": " << o.threads << ", \"device\": " << json_string(o.device) << ", \"in_flight\": ["
      << [&] {
           std::string list;
           for (int n : o.in_flight) list += (list.empty() ? "" : ", ") + std::to_string(n);
           return list;
         }() << "]"
      << ", \"timing\": " << json_string(kTimingNote)
      << ",\n    \"frontend\": {\"scale_factor\": " << s.scale_factor
      << ", \"fast_threshold\": " << s.fast_threshold << ", \"min_arc\": " << s.min_arc
      << ", \"max_arc\": " << s.max_arc << ", \"edge\": " << s.edge << ", \"cell\": " << s.cell_width
      << ", \"pfa\": " << (s.pfa ? "true" : "false") << ", \"pfa_window\": " << s.pfa_window
      << ", \"orientation_bins\": " << s.orientation_bins
      << ", \"stereo_max_disparity\": " << s.stereo_max_disparity
      << ", \"stereo_max_hamming\": " << s.stereo_max_hamming
      << "},\n    \"data\": " << json_string(r.data_folder) << ",\n    \"inputs\": {";
  for (std::size_t i = 0; i < r.inputs.size(); ++i)
    out << (i ? ", " : "") << "\n      " << json_string(r.inputs[i].first) << ": "
        << json_string(r.inputs[i].second);
  out << "}},\n  \"results\": [";
  for (std::size_t i = 0; i < r.rows.size(); ++i) {
    const Row& row = r.rows[i];
    out << (i ? "," : "") << "\n    {\"backend\": " << json_string(row.backend) << ", \"resolution\": \""
        << row.size.text() << "\", \"width\": " << row.size.width << ", \"height\": " << row.size.height
        << ", \"levels\": " << row.levels << ", \"mode\": \"" << mode_name(row.mode) << "\"";
    if (row.backend != kPeerName)
      out << ", \"in_flight\": " << row.in_flight << ", \"input\": \"" << (row.pinned_input ? "pinned" : "copy") << "\"";
    if (!row.error.empty()) {
      out << ", \"error\": " << json_string(row.error) << "}";
      continue;
    }
    out << ", \"frames\": " << row.us.size() << ", \"mean_us\": " << row.mean() << ", \"median_us\": " << row.median()
        << ", \"p10_us\": " << row.percentile(10) << ", \"p90_us\": " << row.percentile(90)
        << ", \"min_us\": " << row.us.front() << ", \"max_us\": " << row.us.back()
        << ", \"frames_per_s\": " << row.frames_per_s() << ", \"mean_keypoints\": " << row.mean_keypoints;
    if (row.mode == BenchMode::stereo) out << ", \"mean_matches\": " << row.mean_matches;
    if (row.backend == kPeerName) out << ", \"nfeatures\": " << row.peer_nfeatures;
    if (row.backend != kPeerName)
      out << ", \"submit_median_us\": " << median_of(row.submit_us)
          << ", \"collect_median_us\": " << median_of(row.collect_us);
    if (row.speedup > 0) out << ", \"speedup_vs_peer\": " << row.speedup;
    if (r.options.profile_kernels && row.backend != kPeerName)
      out << ", \"kernels\": " << kernel_profile_json(row.kernels, row.us.size());
    out << "}";
  }
  out << "\n  ]\n}\n";
}

// ---- The run -------------------------------------------------------------------------------------

// The asked backends, or cpu plus every other one available here; created before any timing so a
// missing backend fails at once.
std::vector<std::unique_ptr<Backend>> create_backends(const BenchOptions& options) {
  std::vector<std::string> names = options.backends;
  if (names.empty()) {
    names.push_back("cpu");
    for (const BackendInfo& info : BackendRegistry::instance().list())
      if (info.available && info.name != "cpu") names.push_back(info.name);
  }
  BackendOptions backend_options;
  backend_options.threads = options.threads;
  backend_options.device = options.device;
  backend_options.profile_kernels = options.profile_kernels;
  std::vector<std::unique_ptr<Backend>> backends;
  for (const auto& name : names)
    backends.push_back(BackendRegistry::instance().create(name, backend_options));
  return backends;
}

void progress(const Row& row, std::size_t done, std::size_t total, double seconds) {
  std::fprintf(stderr, "[%zu/%zu] %-10s %-9s levels %d %-7s ", done, total, row.label().c_str(),
               row.size.text().c_str(), row.levels, mode_name(row.mode));
  if (row.error.empty() && row.backend != kPeerName)
    std::fprintf(stderr, "median %9.0f us  %8.1f frames/s  (host: submit %.1f us, collect %.1f us; %.1f s)\n",
                 row.median(), row.frames_per_s(), median_of(row.submit_us), median_of(row.collect_us), seconds);
  else if (row.error.empty())
    std::fprintf(stderr, "median %9.0f us  %8.1f frames/s  (%.1f s)\n", row.median(), row.frames_per_s(),
                 seconds);
  else
    std::fprintf(stderr, "%s\n", row.error.c_str());
}

// One cell: our rows, then the peer's. A backend that fails the cell gets a row saying why and the
// run goes on, so that one unfinished kernel does not cost a run of many minutes.
void run_cell(Report& report, const std::vector<std::unique_ptr<Backend>>& backends,
              const BenchFrames& frames, const Row& cell, std::size_t total) {
  const std::size_t first_row = report.rows.size();
  for (const auto& backend : backends) {
    for (const int in_flight : report.options.in_flight) {
      if (in_flight > 1 && backend->queue_count() < 2) continue;  // runs frames in order: as in_flight 1
      for (const bool pinned : report.options.pinned_input) {
        Row row(backend->name(), cell.size, cell.levels, cell.mode, in_flight, pinned);
        const Clock::time_point t0 = Clock::now();
        try {
          time_ours(row, *backend, frames, report.options);
        } catch (const std::exception& e) {
          row.error = std::string("failed: ") + e.what();
        }
        report.rows.push_back(std::move(row));
        progress(report.rows.back(), report.rows.size(), total, elapsed_us(t0) / 1e6);
      }
    }
  }
  if (!report.options.peer || !kPeerBuilt) return;
  Row peer(kPeerName, cell.size, cell.levels, cell.mode);
  const auto ours = report.rows.begin() + static_cast<std::ptrdiff_t>(first_row);
  const auto reference = std::find_if(ours, report.rows.end(), [](const Row& r) { return r.error.empty(); });
  const Clock::time_point t0 = Clock::now();
  if (reference == report.rows.end()) {
    peer.error = "skipped: no backend finished this cell, so there is no keypoint count to ask for";
  } else {
    peer.peer_nfeatures = std::max(1, static_cast<int>(std::lround(reference->mean_keypoints)));
    time_peer(peer, frames, report.options);
    for (auto row = ours; row != report.rows.end(); ++row)
      if (row->error.empty()) row->speedup = peer.median() / row->median();
  }
  report.rows.push_back(std::move(peer));
  progress(report.rows.back(), report.rows.size(), total, elapsed_us(t0) / 1e6);
}

int run(const BenchOptions& options) {
  if (!options.json.empty()) check_output_file("--json", options.json);
  const std::vector<std::unique_ptr<Backend>> backends = create_backends(options);
  const DataFolder data = locate_data_folder(options.data);

  Report report;
  report.options = options;
  report.machine = describe_machine();
  for (const auto& b : backends) report.devices.emplace_back(b->name(), b->device_name());
  report.data_folder = data.path.empty() ? "none found" : data.path.string() + " (" + data.origin + ")";

  const Clock::time_point start = Clock::now();
  std::size_t rows_per_cell = options.peer && kPeerBuilt ? 1 : 0;
  for (const auto& b : backends)
    for (const int n : options.in_flight)
      rows_per_cell += (n == 1 || b->queue_count() > 1 ? 1 : 0) * options.pinned_input.size();
  const std::size_t total = options.resolutions.size() * options.levels.size() * options.modes.size() * rows_per_cell;
  if (options.peer && !kPeerBuilt)
    std::fprintf(stderr, "portaslam bench: %s: no %s rows; %s\n", kPeerNotBuilt, kPeerName, kPythonPeerHint);
  for (const Resolution& size : options.resolutions) {
    const BenchFrames frames = load_bench_frames(data, size);
    report.inputs.emplace_back(size.text(), frames.source);
    for (int levels : options.levels)
      for (BenchMode mode : options.modes)
        run_cell(report, backends, frames, Row("", size, levels, mode), total);
  }
  report.seconds = elapsed_us(start) / 1e6;

  print_header(report);
  print_table(report);
  if (options.profile_kernels) {
    std::vector<KernelProfileRow> profiles;
    for (const Row& row : report.rows) {
      if (row.backend == kPeerName || !row.error.empty()) continue;
      profiles.push_back({row.label() + ", " + row.size.text() + ", " + std::to_string(row.levels) + " levels, " +
                              mode_name(row.mode),
                          row.us.size(), row.kernels});
    }
    print_kernel_profiles(profiles, stdout);
  }
  if (!options.json.empty()) {
    std::ostringstream json;
    write_json(json, report);
    try {
      slam::write_file_atomically(options.json, json.str());
    } catch (const slam::AtomicWriteError& e) {
      throw CliError(e.what());
    }
    std::printf("wrote %s\n", options.json.c_str());
  }
  const auto failed = std::count_if(report.rows.begin(), report.rows.end(),
                                    [](const Row& row) { return row.error.rfind("failed", 0) == 0; });
  if (failed == 0) return 0;
  std::fprintf(stderr, "portaslam bench: %ld of the %zu rows failed; the table says why\n",
               static_cast<long>(failed), report.rows.size());
  return 1;
}

}  // namespace

int bench_command(const std::vector<std::string>& args) {
  const char* const who = "portaslam bench: ";
  try {
    const BenchOptions options = parse_bench_options(args);
    if (options.help) {
      std::cout << bench_usage();
      return 0;
    }
    return run(options);
  } catch (const BackendError& e) {
    std::cerr << who << e.what() << "\n(`portaslam backends` lists what this binary has and can use)\n";
  } catch (const std::exception& e) {  // CliError: the message says it all; anything else failed
    std::cerr << who << (dynamic_cast<const CliError*>(&e) ? "" : "failed: ") << e.what() << '\n';
  }
  return 1;
}

}  // namespace porta::app
