// A rendered stereo sequence: from options (trajectory or built-in path, world, camera, frame
// selection, image effects) to a plan (the world, the textures, one pose per frame), to rendered
// frames, to a dataset on disk in KITTI or EuRoC layout (sequence_writer.cpp). Everything is a pure
// function of the options: the same options give the same bytes whatever the thread count.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "porta/image.hpp"
#include "porta/slam/pose.hpp"
#include "porta/slam/render/camera_path.hpp"
#include "porta/slam/render/rasterizer.hpp"
#include "porta/slam/render/texture.hpp"
#include "porta/slam/render/world.hpp"
#include "porta/slam/stereo_camera.hpp"
#include "porta/slam/trajectory_io.hpp"

namespace porta::slam::render {

enum class WorldKind { automatic, street, room };
enum class Layout { kitti, euroc };

/// A user's mistake in the options or the input (what() says which and what to do).
class RenderError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct RenderOptions {
  // Where the poses come from: a trajectory file, else a built-in path (default street-loop).
  std::string trajectory_path;
  std::optional<TrajectoryFormat> format;       ///< default: detected from the file
  std::string kitti_times_path;                 ///< times.txt for a KITTI pose file
  std::optional<BuiltinPath> builtin;
  std::optional<bool> poses_are_body;           ///< default: KITTI = camera, TUM/EuRoC = body
  std::optional<Eigen::Vector3d> up;            ///< input world's up axis; default KITTI -y, else z

  WorldKind world = WorldKind::automatic;       ///< automatic: street for paths wider than 30 m
  std::optional<Layout> layout;                 ///< default: kitti for street, euroc for room
  std::string out_dir;

  // Camera (unset: KITTI-like for street, EuRoC-like for room).
  std::optional<int> width, height;
  std::optional<double> fx, fy, cx, cy, baseline_m;

  // Frames.
  int stride = 1;
  std::optional<double> fps;                    ///< resample at this rate (interpolated poses)
  std::size_t first = 0;
  std::optional<std::size_t> count;             ///< default: all (200 for the default run)

  // Images.
  std::uint64_t seed = 1;
  int supersample = 2;
  double noise_sigma = 1.0;                     ///< Gaussian noise, grey levels
  double exposure_amplitude = 0.0;              ///< relative gain swing (0.2 = +-20 %) plus offset
  double motion_blur = 0.0;                     ///< shutter as a fraction of the frame interval
  int blur_samples = 5;                         ///< sub-frame renders per image when blurring
  int threads = 0;                              ///< 0 = all hardware threads
  int texture_size = 512;
};

/// One frame to render.
struct PlannedFrame {
  std::size_t index = 0;   ///< in the sampled sequence (noise and blur keys: a range renders the same bytes)
  double time_s = 0.0;
  SE3 render_cam;          ///< left camera, z-up render world
  SE3 render_cam_previous; ///< the previous sampled frame's (motion blur), = render_cam for the first
  SE3 input_cam;           ///< left camera in the input's world
  SE3 input_body;          ///< body (camera * T_body_cam0^-1 for camera inputs) in the input's world
};

struct SequencePlan {
  RenderOptions options;   ///< with every default resolved
  StereoCamera camera;
  WorldKind world_kind = WorldKind::street;
  Layout layout = Layout::kitti;
  std::string source;      ///< "street-loop (built-in)" or the trajectory file
  std::shared_ptr<const World> world;
  std::shared_ptr<const TextureBank> textures;
  std::vector<PlannedFrame> frames;
  SE3 T_body_cam0 = SE3::Identity();
  double start_time_s = 0.0;  ///< time of the first sampled frame (exposure changes start there)
  double rate_hz = 10.0;      ///< nominal frame rate
};

/// Resolves defaults, reads the trajectory, selects frames, builds the world and the textures.
/// Throws RenderError (bad option or frame range), TrajectoryError (bad file).
SequencePlan plan_sequence(const RenderOptions& options);

struct StereoFrame {
  Image left, right;
};
/// Renders frame `k` of the plan (0 <= k < frames.size()) with the plan's effects.
StereoFrame render_frame(const SequencePlan& plan, std::size_t k, Rasterizer& rasterizer);

struct WriteReport {
  std::size_t frames = 0;
  double seconds = 0.0;
};
/// Writes the whole plan to options.out_dir in its layout, `threads` frames at a time, calling
/// `progress(done, total, seconds)` from the calling thread now and then. Throws RenderError when
/// the folder or a file cannot be written.
WriteReport write_sequence(const SequencePlan& plan,
                           const std::function<void(std::size_t, std::size_t, double)>& progress = {});

/// Layout files without images (calib/times/poses or data.csv/sensor.yaml/ground truth).
void write_layout_files(const SequencePlan& plan);
/// Path of frame k's image for camera 0 (left) or 1 (right) in the plan's layout.
std::string image_path(const SequencePlan& plan, std::size_t k, int camera);
/// EuRoC timestamp of a time in seconds (ns, rounded).
long long euroc_ns(double time_s);

}  // namespace porta::slam::render
