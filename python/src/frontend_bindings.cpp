// portaslam.backends(), FrontendSettings, Frontend, Features and StereoFeatures.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "numpy_io.hpp"
#include "porta/frontend.hpp"
#include "porta/registry.hpp"

namespace porta::python {

namespace {

/// Features plus the level scales that place them at level 0.
struct PyFeatures {
  Features features;
  std::vector<std::int32_t> scales_q16;

  py::array_t<double> level0() const {
    const auto n = static_cast<py::ssize_t>(features.keypoints.size());
    py::array_t<double> out({n, py::ssize_t{2}});
    auto m = out.mutable_unchecked<2>();
    for (py::ssize_t i = 0; i < n; ++i) {
      const Keypoint& k = features.keypoints[static_cast<std::size_t>(i)];
      const double scale = scales_q16[k.level] / 65536.0;
      m(i, 0) = k.x * scale;
      m(i, 1) = k.y * scale;
    }
    return out;
  }
};

struct PyStereoFeatures {
  PyFeatures left, right;
  std::vector<StereoMatch> matches;
  int num_matches = 0;
};

/// The backend and the Frontend that drives it (the Frontend is destroyed first).
class PyFrontend {
 public:
  PyFrontend(int width, int height, const std::string& backend, const FrontendSettings& settings,
             const std::string& device, int threads) {
    BackendOptions options;
    options.device = device;
    options.threads = threads;
    backend_ = BackendRegistry::instance().create(backend, options);
    frontend_ = std::make_unique<Frontend>(*backend_, settings, width, height);
    settings_ = settings;
  }

  PyFeatures detect(const py::array& image) {
    const ImageView view = image_view(image, "image");
    PyFeatures out;
    {
      py::gil_scoped_release release;
      out.features = frontend_->detect(view);
    }
    out.scales_q16 = frontend_->tables().scales_q16;
    return out;
  }

  PyStereoFeatures detect_stereo(const py::array& left, const py::array& right) {
    const ImageView left_view = image_view(left, "left");
    const ImageView right_view = image_view(right, "right");
    StereoFeatures pair;
    {
      py::gil_scoped_release release;
      pair = frontend_->detect_stereo(left_view, right_view);
    }
    PyStereoFeatures out;
    out.num_matches = pair.num_matches();
    out.left = {std::move(pair.left), frontend_->tables().scales_q16};
    out.right = {std::move(pair.right), frontend_->tables().scales_q16};
    out.matches = std::move(pair.matches);
    return out;
  }

  std::string backend_name() const { return backend_->name(); }
  std::string device_name() const { return backend_->device_name(); }
  const FrontendSettings& settings() const { return settings_; }
  int width() const { return frontend_->pyramid_layout().levels.front().width; }
  int height() const { return frontend_->pyramid_layout().levels.front().height; }

 private:
  std::unique_ptr<Backend> backend_;
  std::unique_ptr<Frontend> frontend_;
  FrontendSettings settings_;
};

}  // namespace

void bind_frontend(py::module_& m) {
  m.def(
      "backends",
      [] {
        py::list out;
        for (const BackendInfo& info : BackendRegistry::instance().list()) {
          py::dict d;
          d["name"] = info.name;
          d["compiled"] = info.compiled;
          d["available"] = info.available;
          d["detail"] = info.detail;
          out.append(d);
        }
        return out;
      },
      "Every backend PortaSLAM knows: name, compiled (built into this module), available (a usable "
      "device was found) and detail (the devices, or why it is unavailable).");

  py::class_<FrontendSettings>(m, "FrontendSettings",
                               "The frontend's settings (DESIGN.md section 3); validate() names a bad field.")
      .def(py::init<>())
      .def_readwrite("levels", &FrontendSettings::levels)
      .def_readwrite("scale_factor", &FrontendSettings::scale_factor)
      .def_readwrite("fast_threshold", &FrontendSettings::fast_threshold)
      .def_readwrite("min_arc", &FrontendSettings::min_arc)
      .def_readwrite("max_arc", &FrontendSettings::max_arc)
      .def_readwrite("edge", &FrontendSettings::edge)
      .def_readwrite("cell_width", &FrontendSettings::cell_width)
      .def_readwrite("cell_height", &FrontendSettings::cell_height)
      .def_readwrite("pfa", &FrontendSettings::pfa)
      .def_readwrite("pfa_window", &FrontendSettings::pfa_window)
      .def_readwrite("orientation_bins", &FrontendSettings::orientation_bins)
      .def_readwrite("stereo_min_disparity", &FrontendSettings::stereo_min_disparity)
      .def_readwrite("stereo_max_disparity", &FrontendSettings::stereo_max_disparity)
      .def_readwrite("stereo_max_hamming", &FrontendSettings::stereo_max_hamming)
      .def("validate", &FrontendSettings::validate)
      .def("__repr__", [](const FrontendSettings& s) {
        return "FrontendSettings(levels=" + std::to_string(s.levels) + ", scale_factor=" +
               py::str(py::float_(s.scale_factor)).cast<std::string>() + ", cell=" + std::to_string(s.cell_width) +
               "x" + std::to_string(s.cell_height) + ", fast_threshold=" + std::to_string(s.fast_threshold) +
               ", pfa=" + (s.pfa ? "True" : "False") + ")";
      });

  py::class_<PyFeatures>(m, "Features", "Keypoints and descriptors of one image, in the canonical order.")
      .def_property_readonly("keypoints", [](const PyFeatures& f) { return keypoints_array(f.features.keypoints); },
                             "(N,) structured array: x, y (at the keypoint's level), response, level, angle_bin; "
                             "the bytes of porta::Keypoint")
      .def_property_readonly("descriptors", [](const PyFeatures& f) { return descriptors_array(f.features.descriptors); },
                             "(N, 32) uint8: 256-bit rBRIEF, bit j in byte j // 8, least significant bit first")
      .def_property_readonly("level0", &PyFeatures::level0, "(N, 2) float64: x, y in level-0 pixels")
      .def_property_readonly("keypoints_per_level", [](const PyFeatures& f) { return f.features.keypoints_per_level; })
      .def("__len__", [](const PyFeatures& f) { return f.features.keypoints.size(); });

  py::class_<PyStereoFeatures>(m, "StereoFeatures", "Features of a rectified pair and the left-to-right matches.")
      .def_readonly("left", &PyStereoFeatures::left)
      .def_readonly("right", &PyStereoFeatures::right)
      .def_property_readonly("matches", [](const PyStereoFeatures& s) { return matches_array(s.matches); },
                             "(N_left,) structured array: disparity_q8 (1/256 px, -1 = none), right_index (-1 = none)")
      .def_readonly("num_matches", &PyStereoFeatures::num_matches);

  py::class_<PyFrontend>(m, "Frontend",
                         "The feature frontend on one backend for images of one size; reuse it for every frame.")
      .def(py::init<int, int, const std::string&, const FrontendSettings&, const std::string&, int>(), py::arg("width"),
           py::arg("height"), py::arg("backend") = "cpu", py::arg("settings") = FrontendSettings{},
           py::arg("device") = "", py::arg("threads") = 0)
      .def("detect", &PyFrontend::detect, py::arg("image"),
           "Features of one (H, W) uint8 image of the Frontend's size. Releases the GIL.")
      .def("detect_stereo", &PyFrontend::detect_stereo, py::arg("left"), py::arg("right"),
           "Features of both images of a rectified pair and the stereo matches. Releases the GIL.")
      .def_property_readonly("backend", &PyFrontend::backend_name)
      .def_property_readonly("device", &PyFrontend::device_name)
      .def_property_readonly("settings", &PyFrontend::settings)
      .def_property_readonly("width", &PyFrontend::width)
      .def_property_readonly("height", &PyFrontend::height);

  m.attr("KEYPOINT_DTYPE") = keypoint_dtype();
  m.attr("MATCH_DTYPE") = match_dtype();
}

}  // namespace porta::python
