// StereoCamera, SlamSettings, System, Trajectory, the dataset readers and the evaluation.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <optional>
#include <string>

#include "bindings.hpp"
#include "numpy_io.hpp"
#include "porta/registry.hpp"
#include "porta/slam/dataset.hpp"
#include "porta/slam/evaluation.hpp"
#include "porta/slam/system.hpp"
#include "porta/slam/trajectory_io.hpp"

namespace porta::python {

namespace {

using slam::Trajectory;

template <typename Enum>
Enum parse_or_throw(const std::optional<Enum>& parsed, const std::string& what, const std::string& value,
                    const char* allowed) {
  if (!parsed) throw py::value_error("unknown " + what + " '" + value + "' (use " + allowed + ")");
  return *parsed;
}

slam::RunMode parse_mode(const std::string& mode) {
  if (mode == "deterministic") return slam::RunMode::deterministic;
  if (mode == "realtime") return slam::RunMode::realtime;
  throw py::value_error("unknown mode '" + mode + "' (use deterministic or realtime)");
}

/// The backend and the System on it (the System is destroyed, and its threads stopped, first).
class PySystem {
 public:
  PySystem(slam::SlamSettings settings, const std::string& backend, const std::string& mode, bool paced,
           const std::string& device, int threads) {
    // As `portaslam run` schedules it (docs/USER_GUIDE.md, "Scheduling"): frames fed at a camera's
    // rate leave mapping the time between them (idle priority); fed as fast as possible, mapping
    // shares the cores equally, or it would starve and tracking run out of map.
    settings.mapping_thread_idle_priority = paced;
    settings.mapping_yields_to_tracking = paced;
    BackendOptions options;
    options.device = device;
    options.threads = threads;
    backend_ = BackendRegistry::instance().create(backend, options);
    system_ = std::make_unique<slam::System>(settings, *backend_, parse_mode(mode));
    camera_ = settings.camera;
  }

  py::dict process(const py::array& left, const py::array& right, double time_s) {
    slam::StereoPair pair;
    pair.index = frames_++;
    pair.time_s = time_s;
    pair.left = Image::copy_of(image_view(left, "left"));
    pair.right = Image::copy_of(image_view(right, "right"));
    slam::TrackingResult result;
    {
      py::gil_scoped_release release;
      result = system_->process(pair);
    }
    py::dict out;
    out["state"] = std::string(slam::to_string(result.state));
    out["tracked"] = result.state == slam::TrackingState::ok;
    out["pose"] = result.state == slam::TrackingState::ok ? py::object(pose_array(result.T_cw.inverse())) : py::none();
    out["keyframe"] = result.keyframe_inserted;
    out["relocalised"] = result.relocalised;
    out["inliers"] = result.matches_local_map;
    out["lost_reason"] = result.lost_reason;
    return out;
  }

  void finish() {
    py::gil_scoped_release release;
    system_->finish();
  }
  Trajectory trajectory() const { return system_->trajectory(); }
  Trajectory keyframe_trajectory() const { return system_->keyframe_trajectory(); }
  void save_map(const std::string& path) const {
    py::gil_scoped_release release;
    system_->save_map(path);
  }
  void load_map(const std::string& path) {
    py::gil_scoped_release release;
    system_->load_map(path);
  }
  std::size_t num_keyframes() const { return system_->map().num_keyframes(); }
  std::size_t num_points() const { return system_->map().num_points(); }
  std::string backend_name() const { return backend_->name(); }

 private:
  std::unique_ptr<Backend> backend_;
  std::unique_ptr<slam::System> system_;
  slam::StereoCamera camera_;
  std::size_t frames_ = 0;
};

py::dict stats_dict(const slam::ErrorStats& s) {
  py::dict d;
  d["count"] = s.count;
  d["rmse"] = s.rmse;
  d["mean"] = s.mean;
  d["median"] = s.median;
  d["std"] = s.std;
  d["min"] = s.min;
  d["max"] = s.max;
  return d;
}

py::dict evaluate(const Trajectory& ground_truth, const Trajectory& estimate, std::size_t rpe_frames) {
  slam::EvaluationOptions options;
  options.rpe.delta_frames = rpe_frames;
  slam::EvaluationResult r;
  {
    py::gil_scoped_release release;
    r = slam::evaluate(ground_truth, estimate, options);
  }
  py::dict out;
  out["pairs"] = r.association.matched();
  out["ate_m"] = stats_dict(r.ate.translation_m);
  out["ate_deg"] = stats_dict(r.ate.rotation_deg);
  out["rpe_m"] = stats_dict(r.rpe.translation_m);
  out["rpe_deg"] = stats_dict(r.rpe.rotation_deg);
  out["rpe_delta"] = r.rpe.delta;
  out["path_length_m"] = r.matched_path_length_m;
  if (r.kitti && r.kitti->segments > 0) {
    out["kitti_t_err_percent"] = r.kitti->translation_percent;
    out["kitti_r_err_deg_per_100m"] = r.kitti->rotation_deg_per_100m;
  }
  return out;
}

}  // namespace

void bind_slam(py::module_& m) {
  py::class_<slam::StereoCamera>(m, "StereoCamera", "A rectified stereo camera: size, intrinsics (px), baseline (m).")
      .def(py::init([](int width, int height, double fx, double fy, double cx, double cy, double baseline_m) {
             slam::StereoCamera c{width, height, fx, fy, cx, cy, baseline_m};
             c.validate();
             return c;
           }),
           py::arg("width"), py::arg("height"), py::arg("fx"), py::arg("fy"), py::arg("cx"), py::arg("cy"),
           py::arg("baseline_m"))
      .def_readonly("width", &slam::StereoCamera::width)
      .def_readonly("height", &slam::StereoCamera::height)
      .def_readonly("fx", &slam::StereoCamera::fx)
      .def_readonly("fy", &slam::StereoCamera::fy)
      .def_readonly("cx", &slam::StereoCamera::cx)
      .def_readonly("cy", &slam::StereoCamera::cy)
      .def_readonly("baseline_m", &slam::StereoCamera::baseline_m)
      .def("__repr__", [](const slam::StereoCamera& c) { return "StereoCamera(" + c.describe() + ")"; });

  py::class_<slam::SlamSettings>(m, "SlamSettings",
                                 "Settings of the SLAM system; SlamSettings(camera) gives the defaults "
                                 "`portaslam run` starts from (cells and disparity range fit to the camera).")
      .def(py::init(&slam::default_settings), py::arg("camera"))
      .def_readonly("camera", &slam::SlamSettings::camera)
      .def_readwrite("frontend", &slam::SlamSettings::frontend)
      .def_readwrite("th_depth", &slam::SlamSettings::th_depth)
      .def_readwrite("loop_closing", &slam::SlamSettings::loop_closing)
      .def_readwrite("global_bundle_adjustment", &slam::SlamSettings::global_bundle_adjustment)
      .def_readwrite("localization_only", &slam::SlamSettings::localization_only)
      .def("validate", &slam::SlamSettings::validate);

  py::class_<Trajectory>(m, "Trajectory", "Time-stamped poses T_world_cam in time order.")
      .def(py::init(&trajectory_from_arrays), py::arg("times"), py::arg("poses"),
           "From times (N,) in seconds and poses (N, 4, 4).")
      .def_property_readonly("times", [](const Trajectory& t) { return py::object(trajectory_arrays(t)[0]); })
      .def_property_readonly("poses", [](const Trajectory& t) { return py::object(trajectory_arrays(t)[1]); })
      .def_readonly("has_times", &Trajectory::has_times)
      .def("path_length_m", &Trajectory::path_length_m)
      .def("__len__", &Trajectory::size)
      .def_static(
          "read", [](const std::string& path) { return slam::read_trajectory(path); }, py::arg("path"),
          "Reads a TUM, KITTI or EuRoC file (the format is detected).")
      .def(
          "write",
          [](const Trajectory& t, const std::string& path, const std::string& format) {
            slam::write_trajectory(path, t,
                                   parse_or_throw(slam::parse_trajectory_format(format), "format", format,
                                                  "tum, kitti or euroc"));
          },
          py::arg("path"), py::arg("format") = "tum");

  py::class_<slam::StereoDataset, std::shared_ptr<slam::StereoDataset>>(m, "Dataset",
                                                                        "A stereo sequence on disk, rectified pairs.")
      .def("__len__", &slam::StereoDataset::size)
      .def_property_readonly("camera", &slam::StereoDataset::camera)
      .def("describe", &slam::StereoDataset::describe)
      .def_property_readonly("ground_truth",
                             [](const slam::StereoDataset& d) -> std::optional<Trajectory> { return d.ground_truth(); })
      .def(
          "__getitem__",
          [](const slam::StereoDataset& d, std::ptrdiff_t i) {
            const auto n = static_cast<std::ptrdiff_t>(d.size());
            if (i < 0) i += n;
            if (i < 0 || i >= n) throw py::index_error("frame " + std::to_string(i) + " of " + std::to_string(n));
            slam::StereoPair pair;
            {
              py::gil_scoped_release release;
              pair = d.load(static_cast<std::size_t>(i));
            }
            return py::make_tuple(image_array(pair.left), pair.right.empty() ? py::object(py::none())
                                                                             : py::object(image_array(pair.right)),
                                  pair.time_s);
          },
          "(left, right, time_s): (H, W) uint8 images, rectified");

  m.def(
      "open_dataset",
      [](const std::string& kind, const std::string& path, const std::string& settings) {
        slam::DatasetOptions options;
        options.settings_path = settings;
        return std::shared_ptr<slam::StereoDataset>(slam::open_dataset(
            parse_or_throw(slam::parse_dataset_kind(kind), "dataset kind", kind, "kitti, euroc or folder"), path,
            options));
      },
      py::arg("kind"), py::arg("path"), py::arg("settings") = "",
      "Opens a KITTI, EuRoC or folder dataset (reads its index and calibration, not the images).");

  py::class_<PySystem>(m, "System", "The stereo SLAM system on one backend.")
      .def(py::init<slam::SlamSettings, const std::string&, const std::string&, bool, const std::string&, int>(),
           py::arg("settings"), py::arg("backend") = "cpu", py::arg("mode") = "deterministic", py::arg("paced") = false,
           py::arg("device") = "", py::arg("threads") = 0,
           "mode: deterministic (mapping completes after each keyframe: same input, same bytes) or realtime "
           "(tracking, local mapping and loop closing in their own threads). paced: frames arrive at a camera's "
           "rate (mapping runs at idle priority between them) rather than as fast as process() is called.")
      .def("process", &PySystem::process, py::arg("left"), py::arg("right"), py::arg("time_s"),
           "Tracks one rectified pair; returns state, tracked, pose (T_world_cam, 4x4, None when lost), keyframe, "
           "relocalised, inliers, lost_reason. Releases the GIL.")
      .def("finish", &PySystem::finish, "Lets mapping (realtime mode) finish; call before the final trajectory.")
      .def("trajectory", &PySystem::trajectory, "Every tracked frame's pose, refined by mapping since.")
      .def("keyframe_trajectory", &PySystem::keyframe_trajectory)
      .def("save_map", &PySystem::save_map, py::arg("path"))
      .def("load_map", &PySystem::load_map, py::arg("path"))
      .def_property_readonly("num_keyframes", &PySystem::num_keyframes)
      .def_property_readonly("num_points", &PySystem::num_points)
      .def_property_readonly("backend", &PySystem::backend_name);

  m.def("evaluate", &evaluate, py::arg("ground_truth"), py::arg("estimate"), py::arg("rpe_frames") = 1,
        "ATE (after SE(3) alignment), RPE and, on KITTI-style paths, the KITTI relative error.");
}

}  // namespace porta::python
