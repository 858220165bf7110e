// `portaslam eval`: evaluates an estimated trajectory against ground truth (slam/eval): associates
// the poses, aligns the estimate, prints ATE, RPE and the KITTI relative errors, and writes a JSON
// report and PNG plots on request.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "cli_args.hpp"
#include "output_paths.hpp"
#include "commands.hpp"
#include "porta/slam/eval_report.hpp"
#include "porta/slam/evaluation.hpp"
#include "porta/slam/trajectory_io.hpp"

namespace porta::app {

namespace {

using slam::AlignmentMethod;
using slam::EvaluationOptions;
using slam::KittiMetric;
using slam::TrajectoryFormat;

struct EvalOptions {
  bool help = false;
  std::vector<std::string> files;  // GT_FILE EST_FILE
  std::optional<TrajectoryFormat> gt_format, est_format;
  std::string gt_times, est_times;
  EvaluationOptions evaluation;
  bool rpe_delta_given = false, rpe_distance_given = false;
  std::optional<bool> kitti;  // --kitti / --no-kitti
  std::string json_path, plots_dir;
};

std::string fmt(const char* format, double value) {
  char text[96];
  std::snprintf(text, sizeof text, format, value);
  std::string s = text;
  // Rounding noise of an exact result prints as "0.0000", not "-0.0000".
  if (s.rfind("-0", 0) == 0 && s.find_first_of("123456789") == std::string::npos) s.erase(0, 1);
  return s;
}

TrajectoryFormat parse_format(const std::string& option, const std::string& value) {
  const auto format = slam::parse_trajectory_format(value);
  if (!format) throw CliError("option " + option + " expects tum, kitti or euroc, got '" + value + "'");
  return *format;
}

void flag(ArgumentCursor& cursor, const std::string& name) {
  if (cursor.has_inline_value()) throw CliError("option " + name + " takes no value");
}

EvalOptions parse_eval_options(const std::vector<std::string>& args) {
  EvalOptions o;
  ArgumentCursor cursor(args);
  while (!cursor.done()) {
    const std::string arg = cursor.take();
    if (arg == "--help" || arg == "-h") {
      o.help = true;
    } else if (arg == "--gt-format") {
      o.gt_format = parse_format(arg, cursor.value(arg));
    } else if (arg == "--est-format") {
      o.est_format = parse_format(arg, cursor.value(arg));
    } else if (arg == "--gt-times") {
      o.gt_times = cursor.value(arg);
    } else if (arg == "--est-times") {
      o.est_times = cursor.value(arg);
    } else if (arg == "--align") {
      const std::string value = cursor.value(arg);
      const auto method = slam::parse_alignment_method(value);
      if (!method) throw CliError("option --align expects se3, sim3 or none, got '" + value + "'");
      o.evaluation.alignment = *method;
    } else if (arg == "--max-time-diff") {
      const double s = parse_double(arg, cursor.value(arg));
      if (s < 0.0) throw CliError("option --max-time-diff expects seconds >= 0, got " + fmt("%g", s));
      o.evaluation.association.max_time_diff_s = s;
    } else if (arg == "--time-offset") {
      o.evaluation.association.time_offset_s = parse_double(arg, cursor.value(arg));
    } else if (arg == "--rpe-delta") {
      const int n = parse_int(arg, cursor.value(arg));
      if (n < 1) throw CliError("option --rpe-delta expects a frame count >= 1, got " + std::to_string(n));
      o.evaluation.rpe.delta_frames = static_cast<std::size_t>(n);
      o.rpe_delta_given = true;
    } else if (arg == "--rpe-distance") {
      const double m = parse_double(arg, cursor.value(arg));
      if (!(m > 0.0)) throw CliError("option --rpe-distance expects metres > 0, got " + fmt("%g", m));
      o.evaluation.rpe.delta_distance_m = m;
      o.rpe_distance_given = true;
    } else if (arg == "--kitti") {
      flag(cursor, arg);
      o.kitti = true;
    } else if (arg == "--no-kitti") {
      flag(cursor, arg);
      o.kitti = false;
    } else if (arg == "--json") {
      o.json_path = cursor.value(arg);
    } else if (arg == "--plots") {
      o.plots_dir = cursor.value(arg);
    } else if (arg.size() > 1 && arg[0] == '-') {
      throw CliError("unknown option '" + arg + "' (see `portaslam eval --help`)");
    } else {
      o.files.push_back(arg);
    }
  }
  if (o.help) return o;
  if (o.files.size() < 2)
    throw CliError(std::string("expected GT_FILE EST_FILE, got ") +
                   (o.files.empty() ? "no file" : "only '" + o.files[0] + "'") +
                   " (see `portaslam eval --help`)");
  if (o.files.size() > 2)
    throw CliError("too many files: expected GT_FILE EST_FILE, the third is '" + o.files[2] + "'");
  if (o.rpe_delta_given && o.rpe_distance_given)
    throw CliError("options --rpe-delta and --rpe-distance exclude each other: give one");
  return o;
}

void require_file(const std::string& what, const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::exists(path, ec)) throw CliError("cannot open " + what + " '" + path + "': no such file");
  if (fs::is_directory(path, ec))
    throw CliError("cannot open " + what + " '" + path + "': it is a directory");
}

struct LoadedTrajectory {
  slam::Trajectory trajectory;
  TrajectoryFormat format;
};

LoadedTrajectory load(const std::string& what, const std::string& path,
                      std::optional<TrajectoryFormat> format, const std::string& times_path,
                      const char* times_option) {
  require_file(what + " file", path);
  if (!times_path.empty()) require_file("times file", times_path);
  try {
    LoadedTrajectory loaded;
    loaded.format = format ? *format : slam::detect_trajectory_format(path);
    if (!times_path.empty() && loaded.format != TrajectoryFormat::kitti)
      throw CliError(std::string("option ") + times_option + " applies to KITTI pose files only, but '" +
                     path + "' is read as " + slam::to_string(loaded.format));
    loaded.trajectory = slam::read_trajectory(path, loaded.format, times_path);
    return loaded;
  } catch (const slam::TrajectoryError& e) {
    throw CliError(what + ": " + e.what());
  }
}

std::string describe_input(const std::string& path, const LoadedTrajectory& t, const std::string& times) {
  std::string s =
      path + " (" + slam::to_string(t.format) + ", " + std::to_string(t.trajectory.size()) + " poses";
  if (!times.empty()) s += ", times from " + times;
  if (!t.trajectory.has_times) s += ", no times";
  return s + ")";
}

void print_summary(const std::string& gt_path, const LoadedTrajectory& gt, const std::string& gt_times,
                   const std::string& est_path, const LoadedTrajectory& est, const std::string& est_times,
                   const EvaluationOptions& options, const slam::EvaluationResult& r) {
  const slam::Association& a = r.association;
  std::ostringstream out;
  out << "ground truth  " << describe_input(gt_path, gt, gt_times) << '\n'
      << "estimate      " << describe_input(est_path, est, est_times) << '\n';
  if (a.by_index) {
    out << "association   by index (a trajectory has no times): " << a.matched() << " pairs\n";
  } else {
    out << "association   by time (max difference " << fmt("%g s", options.association.max_time_diff_s)
        << ", estimate offset " << fmt("%g s", options.association.time_offset_s) << "): " << a.matched()
        << " of " << a.est_count << " estimate poses matched, " << a.unmatched_estimates() << " unmatched; "
        << a.unmatched_ground_truth() << " of " << a.gt_count << " ground-truth poses unused; largest |dt| "
        << fmt("%.4g s", a.max_abs_time_diff_s) << '\n';
  }
  const slam::Alignment& al = r.alignment;
  out << "alignment     " << slam::to_string(al.method);
  if (al.method != AlignmentMethod::none)
    out << ": rotation " << fmt("%.3f deg", slam::rotation_angle_rad(al.rotation) * 180.0 / std::numbers::pi)
        << ", translation [" << fmt("%.4f", al.translation.x()) << ", " << fmt("%.4f", al.translation.y())
        << ", " << fmt("%.4f", al.translation.z()) << "] m, scale " << fmt("%.6f", al.scale);
  out << '\n';
  out << "path length   " << fmt("%.2f m", r.gt_path_length_m) << " ground truth, "
      << fmt("%.2f m", r.matched_path_length_m) << " over the pairs";
  if (r.pair_has_times) out << fmt(", %.2f s", r.matched_duration_s);
  out << '\n';
  const slam::ErrorStats& t = r.ate.translation_m;
  out << "ATE           RMSE " << fmt("%.4f m", t.rmse) << ", mean " << fmt("%.4f", t.mean) << ", median "
      << fmt("%.4f", t.median) << ", std " << fmt("%.4f", t.std) << ", min " << fmt("%.4f", t.min) << ", max "
      << fmt("%.4f m", t.max) << "; rotation RMSE " << fmt("%.3f deg", r.ate.rotation_deg.rmse) << '\n';
  const slam::RpeResult& p = r.rpe;
  out << "RPE           over " << p.delta << ", " << p.translation_m.count << " pairs: translation RMSE "
      << fmt("%.4f m", p.translation_m.rmse) << ", mean " << fmt("%.4f", p.translation_m.mean) << ", median "
      << fmt("%.4f", p.translation_m.median) << ", max " << fmt("%.4f m", p.translation_m.max)
      << "; rotation RMSE " << fmt("%.4f deg", p.rotation_deg.rmse) << ", mean "
      << fmt("%.4f", p.rotation_deg.mean) << ", max " << fmt("%.4f deg", p.rotation_deg.max) << '\n';
  if (!r.kitti) {
    out << "KITTI         not computed (only for index-associated KITTI-style inputs by default; --kitti)\n";
  } else if (r.kitti->segments == 0) {
    out << "KITTI         " << r.kitti->note << '\n';
  } else {
    const slam::KittiResult& k = *r.kitti;
    out << "KITTI         t_err " << fmt("%.3f %%", k.translation_percent) << ", r_err "
        << fmt("%.4f deg/100m", k.rotation_deg_per_100m) << fmt(" (%.6f deg/m)", k.rotation_deg_per_m)
        << " over " << k.segments << " segments\n";
    for (const slam::KittiLengthStats& s : k.per_length)
      out << "              " << fmt("%4.0f m:", s.length_m) << fmt(" t_err %7.3f %%", s.translation_percent)
          << fmt(", r_err %8.4f deg/100m", s.rotation_deg_per_100m) << " (" << s.segments << " segments)\n";
  }
  std::cout << out.str();
}

int run(const EvalOptions& o) {
  const std::string& gt_path = o.files[0];
  const std::string& est_path = o.files[1];
  // Outputs first: a bad --json or --plots path is found before the evaluation, not after it.
  if (!o.json_path.empty()) check_output_file("--json", o.json_path);
  if (!o.plots_dir.empty()) {
    if (!slam::evaluation_plots_available())
      throw CliError("option --plots: plots are drawn with OpenCV, and this build of portaslam has none");
    prepare_output_folder("--plots", o.plots_dir);
  }
  const LoadedTrajectory gt = load("ground truth", gt_path, o.gt_format, o.gt_times, "--gt-times");
  const LoadedTrajectory est = load("estimate", est_path, o.est_format, o.est_times, "--est-times");

  EvaluationOptions options = o.evaluation;
  if (o.kitti) {
    options.kitti = *o.kitti ? KittiMetric::on : KittiMetric::off;
  } else if (gt.format == TrajectoryFormat::kitti && est.format == TrajectoryFormat::kitti) {
    options.kitti = KittiMetric::on;
  }
  slam::EvaluationResult result;
  try {
    result = slam::evaluate(gt.trajectory, est.trajectory, options);
  } catch (const slam::EvaluationError& e) {
    std::string hint;
    const bool by_index = !gt.trajectory.has_times || !est.trajectory.has_times;
    if (by_index && gt.trajectory.size() != est.trajectory.size())
      hint = " with --gt-times FILE / --est-times FILE";
    throw CliError(std::string(e.what()) + hint);
  }
  print_summary(gt_path, gt, o.gt_times, est_path, est, o.est_times, options, result);

  const slam::EvaluationInputs inputs{
      gt_path, est_path, slam::to_string(gt.format), slam::to_string(est.format), o.gt_times, o.est_times};
  try {
    if (!o.json_path.empty()) {
      slam::write_evaluation_json(o.json_path, inputs, options, result);
      std::cout << "wrote " << o.json_path << '\n';
    }
    if (!o.plots_dir.empty()) {
      const std::string title = std::filesystem::path(est_path).filename().string() + " vs " +
                                std::filesystem::path(gt_path).filename().string();
      for (const std::string& file : slam::write_evaluation_plots(o.plots_dir, result, title))
        std::cout << "wrote " << file << '\n';
    }
  } catch (const slam::EvaluationError& e) {
    throw CliError(e.what());
  }
  return 0;
}

}  // namespace

std::string eval_usage() {
  const EvaluationOptions d;
  std::ostringstream u;
  u << "Usage: portaslam eval GT_FILE EST_FILE [OPTIONS]\n"
       "\n"
       "Evaluates an estimated trajectory EST_FILE against the ground truth GT_FILE: pairs the poses,\n"
       "aligns the estimate onto the ground truth, and prints the absolute trajectory error (ATE), the\n"
       "relative pose error (RPE) and the KITTI odometry relative errors. Poses are T_world_frame.\n"
       "Formats: tum (t x y z qx qy qz qw), kitti (12 numbers per line, or 13 with a leading time),\n"
       "euroc (ASL CSV, ns timestamps); detected from the first data line unless given.\n"
       "\n"
       "Inputs:\n"
       "  --gt-format F        tum, kitti or euroc (default: detected)\n"
       "  --est-format F       tum, kitti or euroc (default: detected)\n"
       "  --gt-times FILE      times.txt for a KITTI ground truth (one time in s per pose)\n"
       "  --est-times FILE     times.txt for a KITTI estimate\n"
       "Association (by time when both have times, else by index with equal counts):\n"
       "  --max-time-diff S    largest time difference of a pair, s >= 0 (default "
    << d.association.max_time_diff_s
    << ")\n"
       "  --time-offset S      added to the estimate's times before pairing (default 0)\n"
       "Metrics:\n"
       "  --align A            se3, sim3 (also scale, for monocular) or none (default se3)\n"
       "  --rpe-delta N        RPE over N frames, N >= 1 (default 1)\n"
       "  --rpe-distance M     RPE over M metres of ground-truth path instead, M > 0\n"
       "  --kitti, --no-kitti  KITTI relative errors over 100..800 m segments (default: on when both are\n"
       "                       KITTI files or the pairing is by index)\n"
       "Output:\n"
       "  --json FILE          write every number (and per-pose errors) as JSON\n"
       "  --plots DIR          write trajectory.png (top view), ate.png and rpe.png into DIR\n"
       "\n"
       "Example:\n"
       "  portaslam eval kitti00_poses.txt estimate.txt --gt-times kitti00_times.txt --plots plots\n"
       "\n"
       "Exit status: 0 success; 1 bad option, value or file, or nothing to evaluate (message on stderr).\n";
  return u.str();
}

int eval_command(const std::vector<std::string>& args) {
  const char* const who = "portaslam eval: ";
  try {
    const EvalOptions options = parse_eval_options(args);
    if (options.help) {
      std::cout << eval_usage();
      return 0;
    }
    return run(options);
  } catch (const std::exception& e) {  // CliError: the message says it all; anything else failed
    std::cerr << who << (dynamic_cast<const CliError*>(&e) ? "" : "failed: ") << e.what() << '\n';
  }
  return 1;
}

}  // namespace porta::app
