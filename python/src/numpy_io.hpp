// Conversions between numpy arrays and the engine's types, shared by the binding files: gray
// images in (checked, not copied), keypoints, descriptors, matches and poses out (copied into
// arrays that own their memory).
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>
#include <vector>

#include "porta/image.hpp"
#include "porta/keypoint.hpp"
#include "porta/slam/pose.hpp"

namespace porta::python {

namespace py = pybind11;

/// A view of a 2-D uint8 numpy array whose rows are contiguous (any row stride: a crop works).
/// Throws TypeError naming `what` and what it got otherwise. The array must outlive the view.
ImageView image_view(const py::array& array, const char* what);

/// numpy dtypes laid out byte for byte as porta::Keypoint and porta::StereoMatch.
py::dtype keypoint_dtype();
py::dtype match_dtype();

/// Arrays that own a copy of the data: (N,) keypoints, (N, 32) uint8 descriptors, (N,) matches.
py::array keypoints_array(const std::vector<Keypoint>& keypoints);
py::array descriptors_array(const std::vector<Descriptor>& descriptors);
py::array matches_array(const std::vector<StereoMatch>& matches);

/// A pose as a (4, 4) float64 array, and back (std::invalid_argument unless 4x4 and rigid).
py::array_t<double> pose_array(const slam::SE3& pose);
slam::SE3 pose_from_array(const py::array_t<double, py::array::c_style | py::array::forcecast>& array);

/// A trajectory as (times (N,), poses (N, 4, 4)) and back.
py::tuple trajectory_arrays(const slam::Trajectory& trajectory);
slam::Trajectory trajectory_from_arrays(const py::array_t<double, py::array::c_style | py::array::forcecast>& times,
                                        const py::array_t<double, py::array::c_style | py::array::forcecast>& poses);

/// A copy of a packed image as an (H, W) uint8 array.
py::array image_array(const Image& image);

}  // namespace porta::python
