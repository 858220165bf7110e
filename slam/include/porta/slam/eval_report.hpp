// What `portaslam eval` writes: a JSON report of an evaluation (hand-written JSON, no dependency)
// and PNG plots (drawn with OpenCV): the top view of the aligned estimate over the ground truth, the
// ATE along the trajectory and the RPE along the trajectory.
#pragma once

#include <string>
#include <vector>

#include "porta/slam/evaluation.hpp"

namespace porta::slam {

/// What was evaluated, for the report.
struct EvaluationInputs {
  std::string gt_path, est_path;
  std::string gt_format, est_format;          ///< "tum", "kitti", "euroc"
  std::string gt_times_path, est_times_path;  ///< empty when not given
};

/// The report as a JSON document (one object; see docs/USER_GUIDE.md, "portaslam eval").
std::string evaluation_json(const EvaluationInputs& inputs, const EvaluationOptions& options,
                            const EvaluationResult& result);
/// Writes evaluation_json() to `path`. Throws EvaluationError when the file cannot be written.
void write_evaluation_json(const std::string& path, const EvaluationInputs& inputs,
                           const EvaluationOptions& options, const EvaluationResult& result);

/// Whether this build can draw the plots (they are drawn with OpenCV; a build without it, e.g. on
/// a GPU machine with no OpenCV C++, evaluates and reports but draws nothing).
bool evaluation_plots_available();

/// Writes trajectory.png, ate.png and rpe.png (about 1000x800) into `folder` (created if missing) and
/// returns their paths. `title` heads each plot (e.g. the estimate's file name). Throws
/// EvaluationError when the folder or a file cannot be written, or when plots are not available.
std::vector<std::string> write_evaluation_plots(const std::string& folder, const EvaluationResult& result,
                                                const std::string& title);

}  // namespace porta::slam
