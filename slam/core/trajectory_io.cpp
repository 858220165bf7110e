#include "porta/slam/trajectory_io.hpp"

#include "porta/slam/atomic_file.hpp"

#include <charconv>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <sstream>
#include <vector>

namespace porta::slam {

namespace {

[[noreturn]] void fail(const std::string& path, std::size_t line, const std::string& what) {
  std::string message = "trajectory file " + path;
  if (line > 0) message += ", line " + std::to_string(line);
  throw TrajectoryError(message + ": " + what);
}

struct DataLine {
  std::size_t number = 0;  // 1-based line number in the file
  std::string text;
};

/// Non-empty lines that are not '#' comments, with their line numbers.
std::vector<DataLine> read_data_lines(const std::string& path) {
  std::ifstream in(path);
  if (!in) fail(path, 0, "cannot be opened (missing or unreadable)");
  std::vector<DataLine> lines;
  std::string text;
  std::size_t number = 0;
  while (std::getline(in, text)) {
    ++number;
    if (!text.empty() && text.back() == '\r') text.pop_back();
    const auto first = text.find_first_not_of(" \t");
    if (first == std::string::npos || text[first] == '#') continue;
    lines.push_back({number, text.substr(first)});
  }
  if (in.bad()) fail(path, number, "read error");
  return lines;
}

/// Splits on commas (when `comma`) or whitespace; trims fields.
std::vector<std::string> split_fields(const std::string& text, bool comma) {
  std::vector<std::string> fields;
  if (comma) {
    std::stringstream stream(text);
    std::string field;
    while (std::getline(stream, field, ',')) {
      const auto a = field.find_first_not_of(" \t");
      const auto b = field.find_last_not_of(" \t");
      fields.push_back(a == std::string::npos ? std::string() : field.substr(a, b - a + 1));
    }
  } else {
    std::stringstream stream(text);
    std::string field;
    while (stream >> field) fields.push_back(field);
  }
  return fields;
}

double parse_number(const std::string& field, const std::string& path, std::size_t line, std::size_t column) {
  double value = 0.0;
  const char* begin = field.data();
  const char* end = field.data() + field.size();
  if (!field.empty() && *begin == '+') ++begin;
  const auto [ptr, ec] = std::from_chars(begin, end, value);
  if (ec != std::errc() || ptr != end || !std::isfinite(value)) {
    fail(path, line, "field " + std::to_string(column + 1) + " ('" + field + "') is not a finite number");
  }
  return value;
}

Eigen::Quaterniond make_rotation(double w, double x, double y, double z, const std::string& path,
                                 std::size_t line) {
  Eigen::Quaterniond q(w, x, y, z);
  const double norm = q.norm();
  if (!(norm > 1e-6)) fail(path, line, "the quaternion has zero length");
  if (std::abs(norm - 1.0) > 1e-2) {
    fail(path, line, "the quaternion has length " + std::to_string(norm) + " (expected 1)");
  }
  return q.normalized();
}

/// A 3x4 row-major [R | t] whose R must be a rotation (to the precision KITTI files are written with).
SE3 make_pose_from_rows(const double* m, const std::string& path, std::size_t line) {
  Eigen::Matrix3d r;
  r << m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10];
  const double orthogonality = (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (orthogonality > 1e-3 || r.determinant() < 0.0) {
    fail(path, line, "the 3x3 block is not a rotation matrix (R^T R differs from I by " +
                         std::to_string(orthogonality) + ", det " + std::to_string(r.determinant()) + ")");
  }
  SE3 pose = SE3::Identity();
  pose.linear() = Eigen::Quaterniond(r).normalized().toRotationMatrix();  // re-orthonormalised
  pose.translation() << m[3], m[7], m[11];
  return pose;
}

std::vector<double> parse_numbers(const std::vector<std::string>& fields, const std::string& path,
                                  std::size_t line) {
  std::vector<double> values(fields.size());
  for (std::size_t i = 0; i < fields.size(); ++i) values[i] = parse_number(fields[i], path, line, i);
  return values;
}

Trajectory read_tum(const std::string& path, const std::vector<DataLine>& lines) {
  Trajectory trajectory;
  for (const DataLine& line : lines) {
    const auto fields = split_fields(line.text, false);
    if (fields.size() != 8) {
      fail(path, line.number, "expected 8 numbers (TUM: t x y z qx qy qz qw), found " +
                                  std::to_string(fields.size()));
    }
    const auto v = parse_numbers(fields, path, line.number);
    StampedPose p;
    p.time_s = v[0];
    p.pose.linear() = make_rotation(v[7], v[4], v[5], v[6], path, line.number).toRotationMatrix();
    p.pose.translation() << v[1], v[2], v[3];
    trajectory.poses.push_back(p);
  }
  return trajectory;
}

Trajectory read_euroc(const std::string& path, const std::vector<DataLine>& lines) {
  Trajectory trajectory;
  for (const DataLine& line : lines) {
    const auto fields = split_fields(line.text, true);
    if (fields.size() < 8) {
      fail(path, line.number, "expected at least 8 comma-separated fields (EuRoC: timestamp_ns, px, py, pz, "
                              "qw, qx, qy, qz), found " + std::to_string(fields.size()));
    }
    std::int64_t time_ns = 0;
    const auto [ptr, ec] = std::from_chars(fields[0].data(), fields[0].data() + fields[0].size(), time_ns);
    if (ec != std::errc() || ptr != fields[0].data() + fields[0].size()) {
      fail(path, line.number, "the timestamp '" + fields[0] + "' is not an integer number of nanoseconds");
    }
    const std::vector<std::string> pose_fields(fields.begin() + 1, fields.begin() + 8);
    std::vector<double> v(7);
    for (std::size_t i = 0; i < 7; ++i) v[i] = parse_number(pose_fields[i], path, line.number, i + 1);
    StampedPose p;
    p.time_s = static_cast<double>(time_ns) * 1e-9;
    p.pose.linear() = make_rotation(v[3], v[4], v[5], v[6], path, line.number).toRotationMatrix();
    p.pose.translation() << v[0], v[1], v[2];
    trajectory.poses.push_back(p);
  }
  return trajectory;
}

Trajectory read_kitti(const std::string& path, const std::vector<DataLine>& lines,
                      const std::string& times_path) {
  Trajectory trajectory;
  std::size_t columns = 0;
  for (const DataLine& line : lines) {
    const auto fields = split_fields(line.text, false);
    if (fields.size() != 12 && fields.size() != 13) {
      fail(path, line.number, "expected 12 numbers (KITTI: a 3x4 pose row by row) or 13 (time + pose), found " +
                                  std::to_string(fields.size()));
    }
    if (columns == 0) columns = fields.size();
    if (fields.size() != columns) {
      fail(path, line.number, "has " + std::to_string(fields.size()) + " numbers where earlier lines have " +
                                  std::to_string(columns));
    }
    const auto v = parse_numbers(fields, path, line.number);
    const std::size_t offset = columns == 13 ? 1 : 0;
    StampedPose p;
    p.time_s = columns == 13 ? v[0] : static_cast<double>(trajectory.poses.size());
    p.pose = make_pose_from_rows(v.data() + offset, path, line.number);
    trajectory.poses.push_back(p);
  }
  trajectory.has_times = columns == 13;
  if (!times_path.empty()) {
    const auto time_lines = read_data_lines(times_path);
    if (time_lines.size() != trajectory.poses.size()) {
      throw TrajectoryError("times file " + times_path + " has " + std::to_string(time_lines.size()) +
                            " times but the pose file " + path + " has " +
                            std::to_string(trajectory.poses.size()) + " poses");
    }
    for (std::size_t i = 0; i < time_lines.size(); ++i) {
      const auto fields = split_fields(time_lines[i].text, false);
      if (fields.size() != 1) {
        throw TrajectoryError("times file " + times_path + ", line " + std::to_string(time_lines[i].number) +
                              ": expected one number, found " + std::to_string(fields.size()));
      }
      trajectory.poses[i].time_s = parse_number(fields[0], times_path, time_lines[i].number, 0);
    }
    trajectory.has_times = true;
  }
  return trajectory;
}

/// Writes a file whole or not at all (atomic_file.hpp); the error names what the file is.
void write_whole(const std::string& path, const std::string& text, const char* what) {
  try {
    write_file_atomically(path, text);
  } catch (const AtomicWriteError& e) {
    throw TrajectoryError(std::string(what) + ": " + e.what());
  }
}

/// Shortest text that reads back as exactly `value`.
std::string exact(double value) {
  char buffer[64];
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, value);
  return ec == std::errc() ? std::string(buffer, end) : std::string("nan");
}

}  // namespace

std::optional<TrajectoryFormat> parse_trajectory_format(std::string_view name) {
  if (name == "tum") return TrajectoryFormat::tum;
  if (name == "kitti") return TrajectoryFormat::kitti;
  if (name == "euroc") return TrajectoryFormat::euroc;
  return std::nullopt;
}

const char* to_string(TrajectoryFormat format) {
  switch (format) {
    case TrajectoryFormat::tum: return "tum";
    case TrajectoryFormat::kitti: return "kitti";
    case TrajectoryFormat::euroc: return "euroc";
  }
  return "?";
}

TrajectoryFormat detect_trajectory_format(const std::string& path) {
  const auto lines = read_data_lines(path);
  if (lines.empty()) fail(path, 0, "has no poses (empty, or only comments)");
  const DataLine& first = lines.front();
  if (first.text.find(',') != std::string::npos) return TrajectoryFormat::euroc;
  const auto fields = split_fields(first.text, false);
  if (fields.size() == 8) return TrajectoryFormat::tum;
  if (fields.size() == 12 || fields.size() == 13) return TrajectoryFormat::kitti;
  fail(path, first.number, "cannot tell the format: " + std::to_string(fields.size()) +
                               " numbers (TUM has 8, KITTI 12 or 13, EuRoC is comma-separated); "
                               "name the format explicitly");
}

Trajectory read_trajectory(const std::string& path, TrajectoryFormat format, const std::string& kitti_times_path) {
  const auto lines = read_data_lines(path);
  if (lines.empty()) fail(path, 0, "has no poses (empty, or only comments)");
  if (!kitti_times_path.empty() && format != TrajectoryFormat::kitti) {
    throw TrajectoryError("a times file (" + kitti_times_path + ") only applies to KITTI pose files, but " + path +
                          " is read as " + to_string(format));
  }
  Trajectory trajectory;
  switch (format) {
    case TrajectoryFormat::tum: trajectory = read_tum(path, lines); break;
    case TrajectoryFormat::euroc: trajectory = read_euroc(path, lines); break;
    case TrajectoryFormat::kitti: trajectory = read_kitti(path, lines, kitti_times_path); break;
  }
  // Bounds that every real trajectory meets (positions within 1e9 m: ECEF and UTM coordinates fit;
  // times within ~3000 years): beyond them squares and sums overflow and metrics become inf or nan.
  for (std::size_t i = 0; i < trajectory.poses.size(); ++i) {
    const StampedPose& p = trajectory.poses[i];
    if (p.pose.translation().cwiseAbs().maxCoeff() > kMaxTrajectoryCoordinateM) {
      throw TrajectoryError("trajectory file " + path + ": pose " + std::to_string(i) + " has a coordinate beyond " +
                            exact(kMaxTrajectoryCoordinateM) + " m (" + exact(p.pose.translation().cwiseAbs().maxCoeff()) +
                            ")");
    }
    if (std::abs(p.time_s) > kMaxTrajectoryTimeS) {
      throw TrajectoryError("trajectory file " + path + ": pose " + std::to_string(i) + " has the time " +
                            exact(p.time_s) + " s, beyond " + exact(kMaxTrajectoryTimeS) + " s");
    }
  }
  if (trajectory.has_times) {
    for (std::size_t i = 1; i < trajectory.poses.size(); ++i) {
      if (!(trajectory.poses[i].time_s > trajectory.poses[i - 1].time_s)) {
        throw TrajectoryError("trajectory file " + path + ": times must increase, but pose " + std::to_string(i) +
                              " (time " + exact(trajectory.poses[i].time_s) + ") does not come after pose " +
                              std::to_string(i - 1) + " (time " + exact(trajectory.poses[i - 1].time_s) + ")");
      }
    }
  }
  return trajectory;
}

Trajectory read_trajectory(const std::string& path) {
  return read_trajectory(path, detect_trajectory_format(path));
}

void write_trajectory(const std::string& path, const Trajectory& trajectory, TrajectoryFormat format) {
  std::ostringstream out;
  if (format == TrajectoryFormat::tum) out << "# timestamp tx ty tz qx qy qz qw\n";
  if (format == TrajectoryFormat::euroc) {
    out << "#timestamp [ns], p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], "
           "q_RS_z []\n";
  }
  for (const StampedPose& p : trajectory.poses) {
    const Eigen::Vector3d t = p.pose.translation();
    const Eigen::Quaterniond q(p.pose.rotation());
    switch (format) {
      case TrajectoryFormat::tum:
        out << exact(p.time_s) << ' ' << exact(t.x()) << ' ' << exact(t.y()) << ' ' << exact(t.z()) << ' '
            << exact(q.x()) << ' ' << exact(q.y()) << ' ' << exact(q.z()) << ' ' << exact(q.w()) << '\n';
        break;
      case TrajectoryFormat::euroc:
        out << std::llround(p.time_s * 1e9) << ',' << exact(t.x()) << ',' << exact(t.y()) << ',' << exact(t.z())
            << ',' << exact(q.w()) << ',' << exact(q.x()) << ',' << exact(q.y()) << ',' << exact(q.z()) << '\n';
        break;
      case TrajectoryFormat::kitti: {
        const Eigen::Matrix<double, 3, 4> m = p.pose.matrix().topRows<3>();
        for (int r = 0; r < 3; ++r) {
          for (int c = 0; c < 4; ++c) out << (r + c == 0 ? "" : " ") << exact(m(r, c));
        }
        out << '\n';
        break;
      }
    }
  }
  write_whole(path, out.str(), "trajectory file");
}

void write_kitti_times(const std::string& path, const Trajectory& trajectory) {
  std::ostringstream out;
  for (const StampedPose& p : trajectory.poses) out << exact(p.time_s) << '\n';
  write_whole(path, out.str(), "times file");
}

}  // namespace porta::slam
