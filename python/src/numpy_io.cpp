#include "numpy_io.hpp"

#include <cmath>
#include <cstring>
#include <stdexcept>

#include "porta/settings.hpp"

namespace porta::python {

namespace {
std::string shape_of(const py::array& array) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < array.ndim(); ++i) s += (i ? ", " : "") + std::to_string(array.shape(i));
  return s + (array.ndim() == 1 ? ",)" : ")");
}
}  // namespace

ImageView image_view(const py::array& array, const char* what) {
  const std::string dtype = py::str(static_cast<py::object>(array.dtype()));
  if (array.ndim() != 2 || !array.dtype().is(py::dtype::of<std::uint8_t>())) {
    throw py::type_error(std::string(what) + ": expected a 2-D uint8 array (a gray image), got " + dtype +
                         " with shape " + shape_of(array) +
                         (array.ndim() == 3 ? " (convert colour images to gray first, e.g. cv2.cvtColor)" : ""));
  }
  if (array.strides(1) != 1 || array.strides(0) < array.shape(1)) {
    throw py::type_error(std::string(what) + ": the image's rows must be contiguous (strides " +
                         std::to_string(array.strides(0)) + ", " + std::to_string(array.strides(1)) +
                         "); pass numpy.ascontiguousarray(image)");
  }
  if (array.shape(0) > kMaxImageSide || array.shape(1) > kMaxImageSide || array.strides(0) > (1 << 30)) {
    throw py::value_error(std::string(what) + ": image of shape " + shape_of(array) + " is larger than " +
                          std::to_string(kMaxImageSide) + " pixels on a side");
  }
  return ImageView{static_cast<const std::uint8_t*>(array.data()), static_cast<int>(array.shape(1)),
                   static_cast<int>(array.shape(0)), static_cast<int>(array.strides(0))};
}

py::dtype keypoint_dtype() {
  py::list names, formats, offsets;
  auto field = [&](const char* name, const char* format, std::size_t offset) {
    names.append(name);
    formats.append(format);
    offsets.append(offset);
  };
  field("x", "<u2", offsetof(Keypoint, x));
  field("y", "<u2", offsetof(Keypoint, y));
  field("response", "<u2", offsetof(Keypoint, response));
  field("level", "u1", offsetof(Keypoint, level));
  field("angle_bin", "u1", offsetof(Keypoint, angle_bin));
  py::dict spec;
  spec["names"] = names;
  spec["formats"] = formats;
  spec["offsets"] = offsets;
  spec["itemsize"] = sizeof(Keypoint);
  return py::dtype::from_args(spec);
}

py::dtype match_dtype() {
  py::dict spec;
  spec["names"] = py::make_tuple("disparity_q8", "right_index");
  spec["formats"] = py::make_tuple("<i4", "<i4");
  spec["offsets"] = py::make_tuple(offsetof(StereoMatch, disparity_q8), offsetof(StereoMatch, right_index));
  spec["itemsize"] = sizeof(StereoMatch);
  return py::dtype::from_args(spec);
}

namespace {
template <typename T>
py::array copy_records(const std::vector<T>& items, const py::dtype& dtype) {
  py::array out(dtype, std::vector<py::ssize_t>{static_cast<py::ssize_t>(items.size())});
  if (!items.empty()) std::memcpy(out.mutable_data(), items.data(), items.size() * sizeof(T));
  return out;
}
}  // namespace

py::array keypoints_array(const std::vector<Keypoint>& keypoints) { return copy_records(keypoints, keypoint_dtype()); }
py::array matches_array(const std::vector<StereoMatch>& matches) { return copy_records(matches, match_dtype()); }

py::array descriptors_array(const std::vector<Descriptor>& descriptors) {
  py::array_t<std::uint8_t> out({static_cast<py::ssize_t>(descriptors.size()), py::ssize_t{32}});
  if (!descriptors.empty()) std::memcpy(out.mutable_data(), descriptors.data(), descriptors.size() * sizeof(Descriptor));
  return out;
}

py::array_t<double> pose_array(const slam::SE3& pose) {
  py::array_t<double> out({4, 4});
  auto m = out.mutable_unchecked<2>();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = pose.matrix()(r, c);
  return out;
}

slam::SE3 pose_from_array(const py::array_t<double, py::array::c_style | py::array::forcecast>& array) {
  if (array.ndim() != 2 || array.shape(0) != 4 || array.shape(1) != 4) {
    throw std::invalid_argument("a pose must be a 4x4 array");
  }
  auto m = array.unchecked<2>();
  Eigen::Matrix4d matrix;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) matrix(r, c) = m(r, c);
  const Eigen::Matrix3d rotation = matrix.topLeftCorner<3, 3>();
  const double error = (rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).norm();
  if (!matrix.allFinite() || error > 1e-6 || std::abs(rotation.determinant() - 1.0) > 1e-6 ||
      matrix.row(3) != Eigen::RowVector4d(0, 0, 0, 1)) {
    throw std::invalid_argument("a pose must be rigid: an orthonormal rotation with determinant 1 and a last row 0 0 0 1");
  }
  slam::SE3 pose = slam::SE3::Identity();
  pose.linear() = rotation;
  pose.translation() = matrix.topRightCorner<3, 1>();
  return pose;
}

py::tuple trajectory_arrays(const slam::Trajectory& trajectory) {
  const auto n = static_cast<py::ssize_t>(trajectory.size());
  py::array_t<double> times(n);
  py::array_t<double> poses({n, py::ssize_t{4}, py::ssize_t{4}});
  auto t = times.mutable_unchecked<1>();
  auto p = poses.mutable_unchecked<3>();
  for (py::ssize_t i = 0; i < n; ++i) {
    const auto& stamped = trajectory.poses[static_cast<std::size_t>(i)];
    t(i) = stamped.time_s;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) p(i, r, c) = stamped.pose.matrix()(r, c);
  }
  return py::make_tuple(times, poses);
}

slam::Trajectory trajectory_from_arrays(const py::array_t<double, py::array::c_style | py::array::forcecast>& times,
                                        const py::array_t<double, py::array::c_style | py::array::forcecast>& poses) {
  if (times.ndim() != 1 || poses.ndim() != 3 || poses.shape(1) != 4 || poses.shape(2) != 4 ||
      poses.shape(0) != times.shape(0)) {
    throw std::invalid_argument("a trajectory needs times of shape (N,) and poses of shape (N, 4, 4)");
  }
  slam::Trajectory trajectory;
  auto t = times.unchecked<1>();
  for (py::ssize_t i = 0; i < times.shape(0); ++i) {
    if (!std::isfinite(t(i))) throw std::invalid_argument("trajectory time " + std::to_string(i) + " is not finite");
    if (i > 0 && t(i) < t(i - 1)) throw std::invalid_argument("trajectory times must not decrease (at " + std::to_string(i) + ")");
    py::array_t<double> one({4, 4});
    std::memcpy(one.mutable_data(), poses.data(i), 16 * sizeof(double));
    trajectory.poses.push_back({t(i), pose_from_array(one)});
  }
  return trajectory;
}

py::array image_array(const Image& image) {
  py::array_t<std::uint8_t> out({static_cast<py::ssize_t>(image.height()), static_cast<py::ssize_t>(image.width())});
  for (int y = 0; y < image.height(); ++y) {
    std::memcpy(out.mutable_data(y, 0), image.row(y), static_cast<std::size_t>(image.width()));
  }
  return out;
}

}  // namespace porta::python
