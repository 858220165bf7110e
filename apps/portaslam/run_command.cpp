// `portaslam run`: the stereo SLAM pipeline over a KITTI, EuRoC or folder dataset.
#include <iostream>
#include <string>
#include <vector>

#include "cli_args.hpp"
#include "commands.hpp"
#include "porta/registry.hpp"
#include "porta/settings.hpp"
#include "porta/slam/dataset.hpp"
#include "porta/slam/settings_file.hpp"
#include "porta/slam/trajectory_io.hpp"
#include "slam_run.hpp"

namespace porta::app {

std::string run_usage() {
  return "Usage: portaslam run --dataset kitti|euroc|folder PATH [OPTIONS]\n"
         "\n"
         "Runs stereo SLAM (frontend on a compute backend, tracking, local mapping with bundle\n"
         "adjustment) over a dataset, prints progress and per-stage timing, writes the trajectory and,\n"
         "when the dataset has ground truth, prints the ATE.\n"
         "\n"
         "Datasets: kitti = KITTI odometry layout (image_0/, image_1/, calib.txt, times.txt[, poses.txt]);\n"
         "euroc = EuRoC ASL (mav0/cam0, mav0/cam1, rectified from sensor.yaml); folder = left/ and right/\n"
         "image folders with a --settings file for the camera.\n"
         "\n"
         "Options:\n" +
         slam_run_options_usage() +
         "\n"
         "Examples:\n"
         "  portaslam render --out seq && portaslam run --dataset kitti seq\n"
         "  portaslam run --dataset euroc ../shared/data/euroc-v101-head --mode deterministic\n";
}

int run_command(const std::vector<std::string>& args) {
  const char* const who = "portaslam run: ";
  try {
    SlamRunOptions options;
    bool have_dataset = false;
    ArgumentCursor cursor(args);
    while (!cursor.done()) {
      const std::string option = cursor.take();
      if (option == "--help" || option == "-h") {
        std::cout << run_usage();
        return 0;
      }
      if (option == "--dataset") {
        const std::string kind = cursor.value(option);
        const auto parsed = slam::parse_dataset_kind(kind);
        if (!parsed) throw CliError("--dataset must be kitti, euroc or folder, got '" + kind + "'");
        options.kind = *parsed;
        if (cursor.done()) throw CliError("--dataset " + kind + " needs a PATH after the kind");
        options.path = cursor.take();
        have_dataset = true;
        continue;
      }
      if (!parse_slam_run_option(option, cursor, options)) {
        throw CliError("unknown option '" + option + "' (see portaslam run --help)");
      }
    }
    if (!have_dataset) throw CliError("no dataset given: use --dataset kitti|euroc|folder PATH");
    run_slam(options);
    return 0;
  } catch (const CliError& e) {
    std::cerr << who << e.what() << '\n';
  } catch (const BackendError& e) {
    std::cerr << who << e.what() << "\n(`portaslam backends` lists what this binary has and can use)\n";
  } catch (const slam::DatasetError& e) {
    std::cerr << who << e.what() << '\n';
  } catch (const slam::SettingsFileError& e) {
    std::cerr << who << e.what() << '\n';
  } catch (const slam::TrajectoryError& e) {
    std::cerr << who << e.what() << '\n';
  } catch (const std::exception& e) {
    std::cerr << who << "failed: " << e.what() << '\n';
  }
  return 1;
}

}  // namespace porta::app
