#include "loop_report.hpp"

#include <algorithm>
#include <cstdio>
#include <sstream>

#include "porta/json_text.hpp"

namespace porta::app {
namespace {

double median_ms(std::vector<std::int64_t> ns) {
  if (ns.empty()) return 0.0;
  std::sort(ns.begin(), ns.end());
  return ns[ns.size() / 2] / 1e6;
}

}  // namespace

LoopReport report_loop_closing(const slam::LoopCloser& closer, bool enabled, std::size_t first_frame,
                               const std::vector<std::size_t>& relocalised_frames) {
  LoopReport report;
  const std::vector<slam::LoopEvent>& loops = closer.loops();
  report.detected = loops.size();
  report.closed = closer.loops_closed();
  report.global_ba_runs = closer.global_ba_runs().size();
  std::vector<std::int64_t> detect_ns;
  for (const slam::LoopTimes& t : closer.times()) detect_ns.push_back(t.detect_ns);

  if (!enabled) {
    std::printf("\nloop closing off (--no-loop-closing)\n");
  } else {
    std::printf("\nloops: %zu detected, %zu closed (place recognition %.2f ms median per keyframe)\n", report.detected,
                report.closed, median_ms(detect_ns));
    for (const slam::LoopEvent& e : loops) {
      if (e.closed) {
        std::printf("  frame %zu -> frame %zu (keyframes %llu -> %llu): closed, %d matches, %d inliers, moved %.3f m, "
                    "verify %.1f ms, correct %.1f ms\n",
                    first_frame + e.frame, first_frame + e.loop_frame, static_cast<unsigned long long>(e.keyframe),
                    static_cast<unsigned long long>(e.loop_keyframe), e.matches, e.inliers, e.correction_m,
                    e.verify_ns / 1e6, e.correct_ns / 1e6);
      } else {
        std::printf("  frame %zu -> frame %zu: rejected: %s\n", first_frame + e.frame, first_frame + e.loop_frame,
                    e.rejected.c_str());
      }
    }
    for (const slam::GlobalBaRun& run : closer.global_ba_runs()) {
      std::printf("  global BA after keyframe %llu: %zu keyframes, %zu points, %d iterations, %.0f ms, %s\n",
                  static_cast<unsigned long long>(run.after_loop_keyframe), run.keyframes, run.points,
                  run.iterations, run.time_ns / 1e6, run.applied ? "applied" : "discarded (a later loop or the end came first)");
    }
  }
  std::printf("relocalisations: %zu", relocalised_frames.size());
  for (std::size_t k = 0; k < relocalised_frames.size() && k < 20; ++k) {
    std::printf("%s%zu", k == 0 ? " at frames " : ", ", relocalised_frames[k]);
  }
  std::printf("%s\n", relocalised_frames.size() > 20 ? ", ..." : "");

  std::ostringstream json;
  json << "\"loop_closing\": {\"enabled\": " << (enabled ? "true" : "false") << ", \"detected\": " << report.detected
       << ", \"closed\": " << report.closed << ", \"detect_median_ms\": " << median_ms(detect_ns) << ", \"loops\": [";
  for (std::size_t k = 0; k < loops.size(); ++k) {
    const slam::LoopEvent& e = loops[k];
    json << (k == 0 ? "" : ", ") << "{\"frame\": " << first_frame + e.frame
         << ", \"loop_frame\": " << first_frame + e.loop_frame << ", \"keyframe\": " << e.keyframe
         << ", \"loop_keyframe\": " << e.loop_keyframe << ", \"matches\": " << e.matches
         << ", \"inliers\": " << e.inliers << ", \"closed\": " << (e.closed ? "true" : "false")
         << ", \"rejected\": " << json_string(e.rejected) << ", \"correction_m\": " << e.correction_m
         << ", \"verify_ms\": " << e.verify_ns / 1e6 << ", \"correct_ms\": " << e.correct_ns / 1e6 << "}";
  }
  json << "], \"global_ba\": [";
  const std::vector<slam::GlobalBaRun>& runs = closer.global_ba_runs();
  for (std::size_t k = 0; k < runs.size(); ++k) {
    json << (k == 0 ? "" : ", ") << "{\"keyframes\": " << runs[k].keyframes << ", \"points\": " << runs[k].points
         << ", \"iterations\": " << runs[k].iterations << ", \"ms\": " << runs[k].time_ns / 1e6
         << ", \"applied\": " << (runs[k].applied ? "true" : "false") << "}";
  }
  json << "]},\n  \"relocalisation\": {\"count\": " << relocalised_frames.size() << ", \"frames\": [";
  for (std::size_t k = 0; k < relocalised_frames.size(); ++k) json << (k == 0 ? "" : ", ") << relocalised_frames[k];
  json << "]}";
  report.json = json.str();
  return report;
}

}  // namespace porta::app
