// portaslam._portaslam: the engine, the SLAM system, the dataset readers and the evaluation for
// Python (docs/PYTHON.md). The package portaslam re-exports it.
//
// Errors: our exception types become Python exceptions of the same name, with the same message the
// `portaslam` program prints: SettingsError is a ValueError; BackendError, DatasetError,
// MapFileError, TrajectoryError, EvaluationError and SettingsFileError are RuntimeErrors.
#include <pybind11/pybind11.h>

#include "bindings.hpp"
#include "porta/backend.hpp"
#include "porta/settings.hpp"
#include "porta/slam/dataset.hpp"
#include "porta/slam/evaluation.hpp"
#include "porta/slam/map_file.hpp"
#include "porta/slam/settings_file.hpp"
#include "porta/slam/trajectory_io.hpp"

namespace py = pybind11;

PYBIND11_MODULE(_portaslam, m) {
  m.doc() = "PortaSLAM: a stereo visual SLAM engine whose feature frontend gives identical bytes on cpu, "
            "cuda, vulkan and opencl";
  py::register_exception<porta::SettingsError>(m, "SettingsError", PyExc_ValueError);
  py::register_exception<porta::BackendError>(m, "BackendError", PyExc_RuntimeError);
  py::register_exception<porta::slam::DatasetError>(m, "DatasetError", PyExc_RuntimeError);
  py::register_exception<porta::slam::MapFileError>(m, "MapFileError", PyExc_RuntimeError);
  py::register_exception<porta::slam::TrajectoryError>(m, "TrajectoryError", PyExc_RuntimeError);
  py::register_exception<porta::slam::EvaluationError>(m, "EvaluationError", PyExc_RuntimeError);
  py::register_exception<porta::slam::SettingsFileError>(m, "SettingsFileError", PyExc_RuntimeError);
  porta::python::bind_frontend(m);
  porta::python::bind_slam(m);
#ifdef PORTA_VERSION
  m.attr("__version__") = PORTA_VERSION;
#endif
}
