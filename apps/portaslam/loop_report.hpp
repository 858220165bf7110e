// The loop-closing and relocalisation part of `portaslam run`'s summary (text and summary.json).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "porta/slam/loop_closer.hpp"

namespace porta::app {

struct LoopReport {
  std::size_t detected = 0, closed = 0, global_ba_runs = 0;
  std::string json;  ///< the "loop_closing" and "relocalisation" members of summary.json
};

/// Prints the loops (detected, closed, with dataset frame numbers: the System's frame id plus
/// `first_frame`), the global bundle adjustments, the loop-closing times and the relocalisations.
LoopReport report_loop_closing(const slam::LoopCloser& closer, bool enabled, std::size_t first_frame,
                               const std::vector<std::size_t>& relocalised_frames);

}  // namespace porta::app
