// porta_place_bench: place recognition (slam/place) measured on a sequence with ground truth.
//
//   porta_place_bench DATASET_DIR [--every N] [--gap N] [--radius M] [--json FILE]
//
// Every N-th left image of a KITTI-layout sequence (what `portaslam render` writes) goes through
// the cpu frontend and becomes a "keyframe" of a PlaceDatabase; before it is added it is queried.
// A query is a true revisit when an earlier keyframe at least `gap` frames older lies within
// `radius` metres and 30 degrees of heading (from the ground truth); the answer is the best-scored
// keyframe at least `gap` frames older. For a range of score thresholds it prints precision and
// recall of that answer, and the costs: database start-up, insert and query time per keyframe.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

#include "porta/frontend.hpp"
#include "porta/registry.hpp"
#include "porta/slam/dataset.hpp"
#include "porta/slam/place_recognition.hpp"

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

int usage(const char* why) {
  std::fprintf(stderr, "porta_place_bench: %s\nusage: porta_place_bench DATASET_DIR [--every N] [--gap N] [--radius M] [--json FILE]\n", why);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace porta;
  if (argc < 2) return usage("no dataset folder given");
  std::string path = argv[1], json_path;
  int every = 3, gap = 100;
  double radius_m = 5.0;
  for (int a = 2; a < argc; ++a) {
    const std::string option = argv[a];
    if (a + 1 >= argc) return usage(("missing value after " + option).c_str());
    const std::string value = argv[++a];
    try {
      if (option == "--every") every = std::stoi(value);
      else if (option == "--gap") gap = std::stoi(value);
      else if (option == "--radius") radius_m = std::stod(value);
      else if (option == "--json") json_path = value;
      else return usage(("unknown option " + option).c_str());
    } catch (const std::exception&) {
      return usage(("bad value for " + option + ": " + value).c_str());
    }
  }
  if (every < 1 || gap < 1 || !(radius_m > 0.0)) return usage("--every and --gap must be >= 1, --radius > 0");
  try {
    const auto dataset = slam::open_dataset(slam::DatasetKind::kitti, path, {});
    if (!dataset->ground_truth()) return usage("the dataset has no ground truth (poses.txt)");
    const slam::Trajectory& truth = *dataset->ground_truth();
    const slam::StereoCamera camera = dataset->camera();
    std::unique_ptr<Backend> backend = BackendRegistry::instance().create("cpu", {});
    Frontend frontend(*backend, FrontendSettings{}, camera.width, camera.height);

    const auto start = Clock::now();
    slam::PlaceDatabase database;
    const double startup_ms = ms_since(start);

    struct Query {
      std::size_t frame = 0;
      bool revisit = false;    // ground truth: an old keyframe nearby
      bool answered = false;   // an old keyframe scored at all
      bool correct = false;    // the best old keyframe is a true revisit
      double score = 0.0;
    };
    std::vector<Query> queries;
    std::vector<std::size_t> stored;  // frame of each keyframe id
    std::vector<double> insert_ms, query_ms, frontend_ms;
    const auto near = [&](std::size_t a, std::size_t b) {
      const slam::SE3& A = truth.poses[a].pose;
      const slam::SE3& B = truth.poses[b].pose;
      const double angle = slam::rotation_angle_rad(A.linear().transpose() * B.linear());
      return (A.translation() - B.translation()).norm() <= radius_m && angle <= 30.0 * std::numbers::pi / 180.0;
    };
    const std::size_t n = std::min(dataset->size(), truth.poses.size());
    for (std::size_t f = 0; f < n; f += static_cast<std::size_t>(every)) {
      const slam::StereoPair pair = dataset->load(f);
      auto t = Clock::now();
      const Features features = frontend.detect(pair.left.view());
      frontend_ms.push_back(ms_since(t));
      t = Clock::now();
      const std::vector<slam::PlaceScore> scores = database.query(features.descriptors);
      query_ms.push_back(ms_since(t));
      Query q;
      q.frame = f;
      for (std::size_t k = 0; k < stored.size(); ++k) {
        if (stored[k] + static_cast<std::size_t>(gap) <= f && near(stored[k], f)) q.revisit = true;
      }
      for (const slam::PlaceScore& s : scores) {
        if (stored[s.keyframe] + static_cast<std::size_t>(gap) > f) continue;  // recent: not a revisit
        q.answered = true;
        q.score = s.score;
        q.correct = near(stored[s.keyframe], f);
        break;
      }
      queries.push_back(q);
      t = Clock::now();
      database.add(stored.size(), features.descriptors);
      insert_ms.push_back(ms_since(t));
      stored.push_back(f);
    }

    std::printf("dataset    %s: %zu keyframes (every %d frames), revisits: an older keyframe (>= %d frames) within %.1f m and 30 deg\n",
                path.c_str(), stored.size(), every, gap, radius_m);
    std::printf("costs      start-up %.3f ms; per keyframe (median): frontend %.2f ms, query %.3f ms, insert %.3f ms; "
                "%zu descriptors in %zu tree nodes, depth %d\n",
                startup_ms, median(frontend_ms), median(query_ms), median(insert_ms), database.descriptors(),
                database.tree().nodes(), database.tree().depth());
    std::size_t revisits = 0;
    for (const Query& q : queries) revisits += q.revisit ? 1 : 0;
    std::printf("queries    %zu, of which true revisits %zu\n\nscore >=  precision  recall   TP   FP   FN\n", queries.size(), revisits);
    std::string json = "{\"keyframes\": " + std::to_string(stored.size()) + ", \"revisits\": " + std::to_string(revisits) +
                       ", \"startup_ms\": " + std::to_string(startup_ms) + ", \"query_ms\": " + std::to_string(median(query_ms)) +
                       ", \"insert_ms\": " + std::to_string(median(insert_ms)) + ", \"thresholds\": [";
    const double thresholds[] = {0.0, 0.01, 0.02, 0.03, 0.05, 0.08, 0.1, 0.15, 0.2};
    for (std::size_t i = 0; i < std::size(thresholds); ++i) {
      int tp = 0, fp = 0, fn = 0;
      for (const Query& q : queries) {
        const bool said = q.answered && q.score >= thresholds[i];
        if (said && q.correct) ++tp;
        if (said && !q.correct) ++fp;
        if (q.revisit && !(said && q.correct)) ++fn;
      }
      const double precision = tp + fp > 0 ? static_cast<double>(tp) / (tp + fp) : 1.0;
      const double recall = tp + fn > 0 ? static_cast<double>(tp) / (tp + fn) : 1.0;
      std::printf("%8.2f  %9.3f  %6.3f %4d %4d %4d\n", thresholds[i], precision, recall, tp, fp, fn);
      json += std::string(i == 0 ? "" : ", ") + "{\"score\": " + std::to_string(thresholds[i]) + ", \"precision\": " +
              std::to_string(precision) + ", \"recall\": " + std::to_string(recall) + ", \"tp\": " + std::to_string(tp) +
              ", \"fp\": " + std::to_string(fp) + ", \"fn\": " + std::to_string(fn) + "}";
    }
    json += "]}\n";
    if (!json_path.empty()) {
      std::ofstream out(json_path);
      if (!(out << json)) {
        std::fprintf(stderr, "porta_place_bench: cannot write '%s'\n", json_path.c_str());
        return 1;
      }
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "porta_place_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
