// The JSON report of an evaluation (eval_report.hpp). Hand-written: a tiny writer that keeps track of
// commas and indentation; numbers round-trip (%.17g), non-finite numbers become null.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "porta/slam/eval_report.hpp"

#include "porta/json_text.hpp"
#include "porta/slam/atomic_file.hpp"

namespace porta::slam {

namespace {

class JsonWriter {
 public:
  std::string text() const { return out_; }

  void begin_object(const char* key = nullptr) { open(key, '{'); }
  void end_object() { close('}'); }
  void begin_array(const char* key = nullptr) { open(key, '['); }
  void end_array() { close(']'); }

  void field(const char* key, const std::string& value) { item(key, quote(value)); }
  void field(const char* key, const char* value) { item(key, quote(value)); }
  void field(const char* key, double value) { item(key, number(value)); }
  void field(const char* key, std::size_t value) { item(key, std::to_string(value)); }
  void field(const char* key, bool value) { item(key, value ? "true" : "false"); }
  void null_field(const char* key) { item(key, "null"); }
  /// A compact array of numbers on one line.
  void numbers(const char* key, const std::vector<double>& values) {
    std::string s = "[";
    for (std::size_t k = 0; k < values.size(); ++k) s += (k ? ", " : "") + number(values[k]);
    item(key, s + "]");
  }
  void indices(const char* key, const std::vector<std::size_t>& values) {
    std::string s = "[";
    for (std::size_t k = 0; k < values.size(); ++k) s += (k ? ", " : "") + std::to_string(values[k]);
    item(key, s + "]");
  }

 private:
  static std::string quote(const std::string& s) { return json_string(s); }
  static std::string number(double v) {
    if (!std::isfinite(v)) return "null";
    // %.15g when it reads back exactly (shorter, "0.1" not "0.10000000000000001"), else %.17g.
    char text[40];
    double back = 0.0;
    std::snprintf(text, sizeof text, "%.15g", v);
    if (std::sscanf(text, "%lf", &back) != 1 || back != v) std::snprintf(text, sizeof text, "%.17g", v);
    return text;
  }
  void newline() {
    out_ += '\n';
    out_.append(2 * depth_, ' ');
  }
  void item(const char* key, const std::string& value) {
    if (!first_) out_ += ',';
    first_ = false;
    if (depth_ > 0) newline();
    if (key) out_ += quote(key) + ": ";
    out_ += value;
  }
  void open(const char* key, char bracket) {
    item(key, std::string(1, bracket));
    ++depth_;
    first_ = true;
  }
  void close(char bracket) {
    --depth_;
    if (!first_) newline();
    out_ += bracket;
    first_ = false;
    if (depth_ == 0) out_ += '\n';
  }

  std::string out_;
  std::size_t depth_ = 0;
  bool first_ = true;
};

void write_stats(JsonWriter& j, const char* key, const ErrorStats& s) {
  j.begin_object(key);
  j.field("count", s.count);
  j.field("rmse", s.rmse);
  j.field("mean", s.mean);
  j.field("median", s.median);
  j.field("std", s.std);
  j.field("min", s.min);
  j.field("max", s.max);
  j.end_object();
}

void write_input(JsonWriter& j, const char* key, const std::string& path, const std::string& format,
                 const std::string& times, std::size_t poses) {
  j.begin_object(key);
  j.field("path", path);
  j.field("format", format);
  if (times.empty()) {
    j.null_field("times_path");
  } else {
    j.field("times_path", times);
  }
  j.field("poses", poses);
  j.end_object();
}

}  // namespace

std::string evaluation_json(const EvaluationInputs& inputs, const EvaluationOptions& options,
                            const EvaluationResult& result) {
  const Association& a = result.association;
  JsonWriter j;
  j.begin_object();
  j.field("tool", "portaslam eval");

  j.begin_object("inputs");
  write_input(j, "ground_truth", inputs.gt_path, inputs.gt_format, inputs.gt_times_path, a.gt_count);
  write_input(j, "estimate", inputs.est_path, inputs.est_format, inputs.est_times_path, a.est_count);
  j.end_object();

  j.begin_object("association");
  j.field("mode", a.by_index ? "index" : "time");
  j.field("max_time_diff_s", options.association.max_time_diff_s);
  j.field("time_offset_s", options.association.time_offset_s);
  j.field("matched", a.matched());
  j.field("unmatched_estimate_poses", a.unmatched_estimates());
  j.field("unmatched_ground_truth_poses", a.unmatched_ground_truth());
  j.field("max_abs_time_diff_s", a.max_abs_time_diff_s);
  j.end_object();

  j.begin_object("alignment");
  j.field("method", to_string(result.alignment.method));
  j.begin_array("rotation");
  for (int row = 0; row < 3; ++row) {
    const Eigen::Vector3d r = result.alignment.rotation.row(row).transpose();
    j.numbers(nullptr, {r.x(), r.y(), r.z()});
  }
  j.end_array();
  const Eigen::Vector3d& t = result.alignment.translation;
  j.numbers("translation", {t.x(), t.y(), t.z()});
  j.field("scale", result.alignment.scale);
  j.end_object();

  j.begin_object("path_length_m");
  j.field("ground_truth", result.gt_path_length_m);
  j.field("matched", result.matched_path_length_m);
  j.end_object();
  if (result.pair_has_times) {
    j.field("matched_duration_s", result.matched_duration_s);
  } else {
    j.null_field("matched_duration_s");
  }

  j.begin_object("ate");
  write_stats(j, "translation_m", result.ate.translation_m);
  write_stats(j, "rotation_deg", result.ate.rotation_deg);
  j.begin_object("per_pose");
  j.indices("gt_index", a.gt_index);
  j.indices("est_index", a.est_index);
  j.numbers(result.pair_has_times ? "time_s" : "frame", result.pair_time_s);
  j.numbers("distance_m", result.pair_distance_m);
  j.numbers("translation_error_m", result.ate.translation_errors_m);
  j.numbers("rotation_error_deg", result.ate.rotation_errors_deg);
  j.end_object();
  j.end_object();

  j.begin_object("rpe");
  j.field("delta", result.rpe.delta);
  j.field("scale_applied", result.alignment.scale);
  j.field("pairs", result.rpe.translation_m.count);
  write_stats(j, "translation_m", result.rpe.translation_m);
  write_stats(j, "rotation_deg", result.rpe.rotation_deg);
  j.end_object();

  if (!result.kitti) {
    j.begin_object("kitti");
    j.field("computed", false);
    j.field("note",
            "not requested (on by default only for KITTI-style inputs: both KITTI files, or association by "
            "index; --kitti turns it on)");
    j.end_object();
  } else {
    const KittiResult& k = *result.kitti;
    j.begin_object("kitti");
    j.field("computed", true);
    j.field("segments", k.segments);
    if (k.segments == 0) {
      j.null_field("translation_percent");
      j.null_field("rotation_deg_per_100m");
      j.null_field("rotation_deg_per_m");
    } else {
      j.field("translation_percent", k.translation_percent);
      j.field("rotation_deg_per_100m", k.rotation_deg_per_100m);
      j.field("rotation_deg_per_m", k.rotation_deg_per_m);
    }
    j.begin_array("per_length");
    for (const KittiLengthStats& s : k.per_length) {
      j.begin_object();
      j.field("length_m", s.length_m);
      j.field("segments", s.segments);
      j.field("translation_percent", s.translation_percent);
      j.field("rotation_deg_per_100m", s.rotation_deg_per_100m);
      j.end_object();
    }
    j.end_array();
    if (!k.note.empty()) j.field("note", k.note);
    j.end_object();
  }
  j.end_object();
  return j.text();
}

void write_evaluation_json(const std::string& path, const EvaluationInputs& inputs,
                           const EvaluationOptions& options, const EvaluationResult& result) {
  const std::string text = evaluation_json(inputs, options, result);
  try {
    write_file_atomically(path, text);
  } catch (const AtomicWriteError& e) {
    throw EvaluationError(std::string("JSON report: ") + e.what());
  }
}

}  // namespace porta::slam
