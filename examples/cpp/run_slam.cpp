// Stereo SLAM on a KITTI-layout folder (e.g. one `portaslam render` wrote) with an installed
// PortaSLAM: the trajectory to trajectory_tum.txt and, when the folder has ground truth, the ATE.
//
//   run_slam SEQUENCE [--backend NAME]
#include <cstdio>
#include <exception>
#include <string>

#include "porta/registry.hpp"
#include "porta/slam/dataset.hpp"
#include "porta/slam/evaluation.hpp"
#include "porta/slam/system.hpp"
#include "porta/slam/trajectory_io.hpp"

namespace slam = porta::slam;

int main(int argc, char** argv) try {
  if (argc != 2 && !(argc == 4 && std::string(argv[2]) == "--backend")) {
    std::fprintf(stderr, "usage: run_slam SEQUENCE [--backend NAME]\n");
    return 2;
  }
  const auto dataset = slam::open_dataset(slam::DatasetKind::kitti, argv[1]);
  auto backend = porta::BackendRegistry::instance().create(argc == 4 ? argv[3] : "cpu");
  slam::System system(slam::default_settings(dataset->camera()), *backend, slam::RunMode::deterministic);
  for (std::size_t i = 0; i < dataset->size(); ++i) system.process(dataset->load(i));
  system.finish();

  const slam::Trajectory trajectory = system.trajectory();
  slam::write_trajectory("trajectory_tum.txt", trajectory, slam::TrajectoryFormat::tum);
  std::printf("%zu of %zu frames tracked, %zu keyframes\n", trajectory.size(), dataset->size(),
              system.keyframe_trajectory().size());
  if (dataset->ground_truth()) {
    const slam::EvaluationResult result = slam::evaluate(*dataset->ground_truth(), trajectory);
    std::printf("ATE RMSE %.4f m over %zu poses\n", result.ate.translation_m.rmse, result.ate.translation_errors_m.size());
  }
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "run_slam: %s\n", e.what());
  return 1;
}
