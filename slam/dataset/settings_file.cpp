#include "porta/slam/settings_file.hpp"

#include <cmath>

#include "dataset_internal.hpp"
#include "yaml_reader.hpp"

namespace porta::slam {

namespace {

using detail::in_quotes;

/// Largest side of a matrix a settings file may hold (K, D, R, P are at most 3x4 or 1x5).
constexpr int kMaxMatrixSide = 16;

class Reader {
 public:
  Reader(const detail::YamlNode& root, const std::string& path) : root_(root), path_(path) {}

  [[noreturn]] void fail(const std::string& key, const std::string& problem) const {
    throw SettingsFileError("settings file " + in_quotes(path_) + ": key '" + key + "' " + problem);
  }

  /// The key's node, or nullptr when it is absent or empty.
  const detail::YamlNode* node(const std::string& key) const {
    const detail::YamlNode* found = root_.find(key);
    return found == nullptr || found->is_null() ? nullptr : found;
  }

  std::optional<double> number(const std::string& key) const {
    const detail::YamlNode* n = node(key);
    if (n == nullptr) return std::nullopt;
    if (!n->is_number()) fail(key, "must be a number, found " + n->describe());
    if (!std::isfinite(n->number)) fail(key, "must be a finite number");
    return n->number;
  }

  std::optional<int> integer(const std::string& key) const {
    const detail::YamlNode* n = node(key);
    if (n == nullptr) return std::nullopt;
    if (n->kind == detail::YamlNode::Kind::integer) return static_cast<int>(n->number);
    if (n->kind == detail::YamlNode::Kind::real) {
      const double value = n->number;
      // ORB-SLAM2's own files write e.g. "Camera.width: 752.0"; a fraction is an error.
      if (std::isfinite(value) && value == std::floor(value) && std::abs(value) < 1e9)
        return static_cast<int>(value);
      fail(key, "must be an integer, found " + detail::format_number(value, 10));
    }
    fail(key, "must be an integer, found " + n->describe());
  }

  std::optional<bool> flag(const std::string& key) const {
    const auto value = integer(key);
    if (!value) return std::nullopt;
    if (*value != 0 && *value != 1) fail(key, "must be 0 or 1, found " + std::to_string(*value));
    return *value == 1;
  }

  /// Row-major values of an !!opencv-matrix (or of a plain list of numbers, for D).
  struct Matrix {
    int rows = 0, cols = 0;
    std::vector<double> values;
  };

  std::vector<double> numbers_of(const std::string& key, const detail::YamlNode& list, const char* what) const {
    std::vector<double> values;
    for (const auto& item : list.items) {
      if (!item.is_number()) fail(key, std::string(what) + " an element that is " + item.describe() + ", not a number");
      values.push_back(item.number);
    }
    return values;
  }

  std::optional<Matrix> matrix(const std::string& key) const {
    const detail::YamlNode* n = node(key);
    if (n == nullptr) return std::nullopt;
    if (n->kind == detail::YamlNode::Kind::list) {
      Matrix m;
      m.values = numbers_of(key, *n, "must be a list of numbers, found");
      if (m.values.empty()) fail(key, "is an empty list; expected numbers");
      m.rows = 1;
      m.cols = static_cast<int>(m.values.size());
      return m;
    }
    if (n->kind != detail::YamlNode::Kind::map) fail(key, "must be an !!opencv-matrix, found " + n->describe());
    const auto size = [&](const char* field) {
      const detail::YamlNode* f = n->find(field);
      if (f == nullptr || f->kind != detail::YamlNode::Kind::integer)
        fail(key, std::string("is not a readable !!opencv-matrix: '") + field + "' must be an integer");
      const int v = static_cast<int>(f->number);
      if (v < 1 || v > kMaxMatrixSide)
        fail(key, std::string("is not a readable !!opencv-matrix: '") + field + "' is " + std::to_string(v) +
                      ", outside [1, " + std::to_string(kMaxMatrixSide) + "]");
      return v;
    };
    Matrix m;
    m.rows = size("rows");
    m.cols = size("cols");
    const detail::YamlNode* data = n->find("data");
    if (data == nullptr || data->kind != detail::YamlNode::Kind::list)
      fail(key, "is not a readable !!opencv-matrix: 'data' must be a list of numbers");
    if (data->items.size() != static_cast<std::size_t>(m.rows) * static_cast<std::size_t>(m.cols))
      fail(key, "is not a readable !!opencv-matrix: " + std::to_string(m.rows) + "x" + std::to_string(m.cols) +
                    " needs " + std::to_string(m.rows * m.cols) + " numbers, 'data' has " +
                    std::to_string(data->items.size()));
    m.values = numbers_of(key, *data, "has a 'data' element that is");
    return m;
  }

  template <int Rows, int Cols>
  std::optional<Eigen::Matrix<double, Rows, Cols>> fixed_matrix(const std::string& key) const {
    const auto m = matrix(key);
    if (!m) return std::nullopt;
    if (m->rows != Rows || m->cols != Cols)
      fail(key, "must be a " + std::to_string(Rows) + "x" + std::to_string(Cols) + " matrix, found " +
                    std::to_string(m->rows) + "x" + std::to_string(m->cols));
    Eigen::Matrix<double, Rows, Cols> out;
    for (int r = 0; r < Rows; ++r)
      for (int c = 0; c < Cols; ++c) out(r, c) = m->values[static_cast<std::size_t>(r * Cols + c)];
    if (!out.allFinite()) fail(key, "has a value that is not a finite number");
    return out;
  }

  std::optional<std::vector<double>> distortion(const std::string& key) const {
    const auto m = matrix(key);
    if (!m) return std::nullopt;
    const int n = m->rows * m->cols;
    if ((m->rows != 1 && m->cols != 1) || (n != 4 && n != 5))
      fail(key, "must be a 1x4 or 1x5 matrix (k1 k2 p1 p2 [k3]), found " + std::to_string(m->rows) + "x" +
                    std::to_string(m->cols));
    if (const auto problem = detail::distortion_problem(m->values)) fail(key, "has a " + *problem);
    return m->values;
  }

  RectificationSide side(const std::string& prefix) const {
    RectificationSide s;
    s.height = integer(prefix + ".height");
    s.width = integer(prefix + ".width");
    s.K = fixed_matrix<3, 3>(prefix + ".K");
    s.D = distortion(prefix + ".D");
    s.R = fixed_matrix<3, 3>(prefix + ".R");
    s.P = fixed_matrix<3, 4>(prefix + ".P");
    return s;
  }

 private:
  const detail::YamlNode& root_;
  const std::string& path_;
};

[[noreturn]] void missing(const std::string& path, const std::string& key, const std::string& needed_for) {
  throw SettingsFileError("settings file " + in_quotes(path) + ": key '" + key + "' is missing (needed for " +
                          needed_for + ")");
}

}  // namespace

SettingsFile read_settings_file(const std::string& path) {
  detail::YamlNode root;
  if (const auto error = detail::read_yaml_file(path, root))
    throw SettingsFileError("settings file " + in_quotes(path) + ": " + *error);
  const Reader read(root, path);
  SettingsFile s;
  s.path = path;
  s.fx = read.number("Camera.fx");
  s.fy = read.number("Camera.fy");
  s.cx = read.number("Camera.cx");
  s.cy = read.number("Camera.cy");
  s.k1 = read.number("Camera.k1");
  s.k2 = read.number("Camera.k2");
  s.p1 = read.number("Camera.p1");
  s.p2 = read.number("Camera.p2");
  s.k3 = read.number("Camera.k3");
  {
    const std::pair<const char*, std::optional<double>> coefficients[] = {
        {"Camera.k1", s.k1}, {"Camera.k2", s.k2}, {"Camera.p1", s.p1}, {"Camera.p2", s.p2}, {"Camera.k3", s.k3}};
    for (const auto& [key, value] : coefficients) {
      if (value && std::abs(*value) > detail::kMaxDistortionCoefficient) {
        throw SettingsFileError("settings file " + in_quotes(path) + ": key '" + key + "' is " +
                                detail::format_number(*value) + ": a distortion coefficient must lie in [-" +
                                detail::format_number(detail::kMaxDistortionCoefficient) + ", " +
                                detail::format_number(detail::kMaxDistortionCoefficient) + "]");
      }
    }
  }
  s.width = read.integer("Camera.width");
  s.height = read.integer("Camera.height");
  s.fps = read.number("Camera.fps");
  s.bf = read.number("Camera.bf");
  s.rgb = read.flag("Camera.RGB");
  s.th_depth = read.number("ThDepth");
  s.orb_features = read.integer("ORBextractor.nFeatures");
  s.orb_scale_factor = read.number("ORBextractor.scaleFactor");
  s.orb_levels = read.integer("ORBextractor.nLevels");
  s.orb_ini_th_fast = read.integer("ORBextractor.iniThFAST");
  s.orb_min_th_fast = read.integer("ORBextractor.minThFAST");
  s.left = read.side("LEFT");
  s.right = read.side("RIGHT");
  if (s.fps && *s.fps <= 0.0)
    throw SettingsFileError("settings file " + in_quotes(path) + ": key 'Camera.fps' must be > 0, found " +
                            detail::format_number(*s.fps));
  return s;
}

void SettingsFile::check_rectification_complete() const {
  if (!left.any() && !right.any()) return;
  const auto check = [&](const RectificationSide& side, const std::string& prefix) {
    const auto need = [&](bool present, const char* key) {
      if (!present)
        missing(path, prefix + "." + key, "stereo rectification: LEFT.* and RIGHT.* come together");
    };
    need(side.height.has_value(), "height");
    need(side.width.has_value(), "width");
    need(side.K.has_value(), "K");
    need(side.D.has_value(), "D");
    need(side.R.has_value(), "R");
    need(side.P.has_value(), "P");
  };
  check(left, "LEFT");
  check(right, "RIGHT");
  if (*left.width != *right.width || *left.height != *right.height)
    throw SettingsFileError("settings file " + in_quotes(path) + ": LEFT is " + std::to_string(*left.width) +
                            "x" + std::to_string(*left.height) + " but RIGHT is " +
                            std::to_string(*right.width) + "x" + std::to_string(*right.height));
}

StereoCamera SettingsFile::stereo_camera() const {
  const char* const needed_for = "the stereo camera";
  const auto need = [&](const auto& value, const char* key) {
    if (!value) missing(path, key, needed_for);
    return *value;
  };
  StereoCamera camera;
  camera.fx = need(fx, "Camera.fx");
  camera.fy = need(fy, "Camera.fy");
  camera.cx = need(cx, "Camera.cx");
  camera.cy = need(cy, "Camera.cy");
  const double bf_value = need(bf, "Camera.bf");
  camera.width = need(width, "Camera.width");
  camera.height = need(height, "Camera.height");
  camera.baseline_m = camera.fx > 0.0 ? bf_value / camera.fx : 0.0;
  try {
    camera.validate();
  } catch (const std::invalid_argument& e) {
    throw SettingsFileError("settings file " + in_quotes(path) +
                            ": bad camera (Camera.fx, fy, cx, cy, bf, width, " + "height): " + e.what());
  }
  return camera;
}

bool SettingsFile::has_distortion() const {
  for (const auto& k : {k1, k2, p1, p2, k3})
    if (k && *k != 0.0) return true;
  return false;
}

void SettingsFile::apply_to(FrontendSettings& settings) const {
  settings.validate();  // the caller's own settings first, so that an error is not blamed on a key
  FrontendSettings result = settings;
  const auto apply = [&](const char* key, auto value, auto& field) {
    if (!value) return;
    const auto previous = field;
    field = *value;
    try {
      result.validate();
    } catch (const SettingsError& e) {
      field = previous;
      throw SettingsFileError("settings file " + in_quotes(path) + ": key '" + key +
                              "' = " + detail::format_number(static_cast<double>(*value)) +
                              " is not usable: " + e.what());
    }
  };
  apply("ORBextractor.nLevels", orb_levels, result.levels);
  apply("ORBextractor.scaleFactor", orb_scale_factor, result.scale_factor);
  apply("ORBextractor.iniThFAST", orb_ini_th_fast, result.fast_threshold);
  settings = result;
}

}  // namespace porta::slam
