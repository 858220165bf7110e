#include "quality/quality_data.hpp"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

namespace porta::quality {

std::filesystem::path default_data_dir() { return PORTA_QUALITY_DEFAULT_DATA_DIR; }

std::filesystem::path resolve_data_dir(const std::string& cli_value) {
  if (!cli_value.empty()) return cli_value;
  if (const char* env = std::getenv("PORTA_DATA_DIR"); env && *env) return env;
  return default_data_dir();
}

cv::Mat load_gray(const std::filesystem::path& path) {
  cv::Mat image = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  if (image.empty()) throw DataError("cannot read image " + path.string());
  if (image.depth() != CV_8U) throw DataError(path.string() + " is not an 8-bit image");
  if (image.channels() == 3) cv::cvtColor(image, image, cv::COLOR_BGR2GRAY);
  if (image.channels() == 4) cv::cvtColor(image, image, cv::COLOR_BGRA2GRAY);
  return image;
}

cv::Matx33d load_homography(const std::filesystem::path& path) {
  if (!std::filesystem::exists(path)) throw DataError("homography file " + path.string() + " is absent");
  cv::FileStorage storage(path.string(), cv::FileStorage::READ);
  if (!storage.isOpened()) throw DataError("cannot open homography file " + path.string());
  const cv::FileNode root = storage.root();
  for (auto it = root.begin(); it != root.end(); ++it) {
    const cv::FileNode node = *it;
    if (!node.isMap() || node["data"].empty()) continue;  // not an opencv-matrix node
    cv::Mat m;
    node >> m;
    if (m.rows != 3 || m.cols != 3)
      throw DataError(path.string() + ": matrix node '" + node.name() + "' is not 3x3");
    m.convertTo(m, CV_64F);
    cv::Matx33d h(m.ptr<double>());
    // A homography is defined up to scale and some files store it negated (leuven H1to5p has
    // h33 = -0.576); fixing h33 = 1 makes w > 0 mean "in front" for every file.
    if (std::abs(h(2, 2)) < 1e-12) throw DataError(path.string() + ": homography has h33 = 0");
    return h * (1.0 / h(2, 2));
  }
  throw DataError(path.string() + " holds no matrix node");
}

cv::Matx33d load_oxford_homography(const std::filesystem::path& data_dir, const std::string& set, int n) {
  return load_homography(data_dir / "oxford-affine" / set / ("H1to" + std::to_string(n) + "p.xml"));
}

cv::Mat load_oxford_image(const std::filesystem::path& data_dir, const std::string& set, int n) {
  return load_gray(data_dir / "oxford-affine" / set / ("img" + std::to_string(n) + ".png"));
}

int load_middlebury_scale(const std::filesystem::path& data_dir, const std::string& scene) {
  const auto path = data_dir / "middlebury" / "scales.xml";
  std::ifstream in(path);
  if (!in) throw DataError("cannot read " + path.string());
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream words(line);
    std::string name, scale;
    if (!(words >> name >> scale) || name != scene) continue;
    if (scale.size() >= 2 && scale.front() == '"' && scale.back() == '"')
      scale = scale.substr(1, scale.size() - 2);
    try {
      const int value = std::stoi(scale);
      if (value > 0) return value;
    } catch (const std::exception&) {
    }
    throw DataError(path.string() + ": scene '" + scene + "' has no positive scale ('" + scale + "')");
  }
  throw DataError(path.string() + " does not list scene '" + scene + "'");
}

StereoScene load_middlebury_scene(const std::filesystem::path& data_dir, const std::string& scene) {
  const auto folder = data_dir / "middlebury" / scene;
  StereoScene s;
  s.name = scene;
  s.left = load_gray(folder / "im2.png");
  s.right = load_gray(folder / "im6.png");
  const cv::Mat encoded = load_gray(folder / "disp2.png");
  if (encoded.size() != s.left.size() || s.right.size() != s.left.size())
    throw DataError(folder.string() + ": im2, im6 and disp2 differ in size");
  s.scale = load_middlebury_scale(data_dir, scene);
  encoded.convertTo(s.true_disparity, CV_32F, 1.0 / s.scale);
  return s;
}

const std::vector<std::string>& oxford_sets() {
  static const std::vector<std::string> sets = {"bark", "bikes", "leuven", "trees", "ubc", "wall"};
  return sets;
}

const std::vector<std::string>& middlebury_scenes() {
  static const std::vector<std::string> scenes = {"barn2", "bull", "poster", "sawtooth", "tsukuba", "venus"};
  return scenes;
}

}  // namespace porta::quality
