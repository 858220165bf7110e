#include "frame_log.hpp"

#include <algorithm>
#include <cstdio>
#include <sstream>

namespace porta::app {
namespace {

std::string ms(std::int64_t ns) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3f", static_cast<double>(ns) * 1e-6);
  return text;
}

}  // namespace

std::string frame_log_csv(std::size_t first_frame, const std::vector<slam::FrameTimes>& times,
                          const std::vector<slam::TrackingResult>& results,
                          const std::vector<std::int64_t>& input_wait_ns) {
  std::string out =
      "frame,state,keyframe,motion_model,motion_hypotheses,relocalised,last_frame_points,predicted_inliers,"
      "motion_inliers,local_map_inliers,mapping_queue,input_wait_ms,frontend_ms,tracking_ms,map_wait_ms,"
      "unlocked_ms,relock_wait_ms,motion_ms,local_map_ms,keyframe_ms,mapping_wait_ms,frame_ms\n";
  const std::size_t n = std::max({times.size(), results.size(), input_wait_ns.size()});
  std::ostringstream line;
  for (std::size_t i = 0; i < n; ++i) {
    line << first_frame + i;
    if (i < results.size()) {
      const slam::TrackingResult& r = results[i];
      line << ',' << slam::to_string(r.state) << ',' << int{r.keyframe_inserted} << ',' << int{r.used_motion_model}
           << ',' << int{r.motion_hypotheses} << ',' << int{r.relocalised} << ',' << r.last_frame_points << ','
           << r.predicted_inliers << ',' << r.matches_motion << ',' << r.matches_local_map << ',' << r.mapping_queue;
    } else {
      line << ",,,,,,,,,,";
    }
    line << ',' << (i < input_wait_ns.size() ? ms(input_wait_ns[i]) : "");
    if (i < times.size()) {
      line << ',' << ms(times[i].frontend_ns) << ',' << ms(times[i].tracking_ns);
    } else {
      line << ",,";
    }
    if (i < results.size()) {
      const slam::TrackingResult& r = results[i];
      line << ',' << ms(r.map_wait_ns) << ',' << ms(r.unlocked_ns) << ',' << ms(r.relock_wait_ns) << ','
           << ms(r.track_motion_ns) << ',' << ms(r.track_local_map_ns) << ',' << ms(r.keyframe_ns);
    } else {
      line << ",,,,,,";
    }
    line << ',' << (i < times.size() ? ms(times[i].mapping_wait_ns) : "") << ','
         << (i < times.size() ? ms(times[i].total_ns) : "") << '\n';
  }
  out += line.str();
  return out;
}

std::string mapping_log_csv(const std::vector<slam::MappingTimes>& times) {
  std::ostringstream out;
  out << "keyframe,queued,interval_ms,spread,process_ms,cull_points_ms,triangulation_ms,fusion_ms,ba_ran,ba_ms,"
         "ba_iterations,cull_keyframes_ms,total_ms,lock_wait_ms\n";
  for (const slam::MappingTimes& t : times) {
    out << t.keyframe_id << ',' << t.queued << ',' << ms(t.interval_ns) << ',' << int{t.spread} << ','
        << ms(t.process_ns) << ',' << ms(t.cull_points_ns) << ',' << ms(t.triangulate_ns) << ',' << ms(t.fuse_ns)
        << ',' << int{t.bundle_adjustment_ran} << ',' << ms(t.bundle_adjustment_ns) << ','
        << t.bundle_adjustment_iterations << ',' << ms(t.cull_keyframes_ns) << ',' << ms(t.total_ns) << ','
        << ms(t.lock_wait_ns) << '\n';
  }
  return out.str();
}

}  // namespace porta::app
