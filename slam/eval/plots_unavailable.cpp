// write_evaluation_plots in a build without OpenCV (plots.cpp draws with it): the evaluation and
// its report work; plots are refused with a message saying why.
#include "porta/slam/eval_report.hpp"
#include "porta/slam/evaluation.hpp"

namespace porta::slam {

bool evaluation_plots_available() { return false; }

std::vector<std::string> write_evaluation_plots(const std::string& folder, const EvaluationResult&,
                                                const std::string&) {
  throw EvaluationError("cannot write plots into '" + folder +
                        "': plots are drawn with OpenCV, and this build of PortaSLAM has none");
}

}  // namespace porta::slam
