// `portaslam run`'s per-frame log, frames.csv: one line per frame with what tracking found and
// where the frame's time went, for the frames the stage table's medians and tails summarise; and
// its per-keyframe log, mapping.csv: where local mapping's time went, keyframe by keyframe.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "porta/slam/local_mapper.hpp"
#include "porta/slam/system.hpp"

namespace porta::app {

/// The CSV text (a header line, then one line per frame, numbered from `first_frame`). `times`,
/// `results` and `input_wait_ns` are per frame, in order; a shorter list leaves its columns empty.
std::string frame_log_csv(std::size_t first_frame, const std::vector<slam::FrameTimes>& times,
                          const std::vector<slam::TrackingResult>& results,
                          const std::vector<std::int64_t>& input_wait_ns);

/// The CSV text of mapping.csv: a header line, then one line per keyframe local mapping processed,
/// in order (LocalMapper::times()).
std::string mapping_log_csv(const std::vector<slam::MappingTimes>& times);

}  // namespace porta::app
