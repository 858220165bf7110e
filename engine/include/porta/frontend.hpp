// The feature frontend: drives any backend through the whole pipeline of DESIGN.md §3 for one
// image or a rectified stereo pair: pyramid -> CRF -> culling -> PFA -> orientation -> blur ->
// descriptors (-> stereo match). One Frontend per settings and image size; reuse it per frame.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "porta/backend.hpp"
#include "porta/image.hpp"
#include "porta/keypoint.hpp"
#include "porta/settings.hpp"
#include "porta/sync_buffer.hpp"
#include "porta/tables.hpp"

namespace porta {

/// Wall-clock time of each stage of the last call, in nanoseconds. Stages are only separated
/// (with a synchronize between them) when `FrontendOptions::profile_stages` is set; otherwise
/// only `total_ns` is filled.
struct StageTimes {
  std::int64_t upload_ns = 0;
  std::int64_t pyramid_ns = 0;
  std::int64_t fast_ns = 0;
  std::int64_t cull_ns = 0;
  std::int64_t pfa_ns = 0;
  std::int64_t orient_ns = 0;
  std::int64_t blur_ns = 0;
  std::int64_t describe_ns = 0;
  std::int64_t stereo_ns = 0;
  std::int64_t download_ns = 0;
  std::int64_t total_ns = 0;
};

struct Features {
  std::vector<Keypoint> keypoints;        ///< canonical order: level, then cell
  std::vector<Descriptor> descriptors;    ///< one per keypoint (empty when not described)
  std::vector<int> keypoints_per_level;

  /// Level-0 position of keypoint i in pixels (x * s^n with the table's Q16 scale).
  double level0_x(std::size_t i, const FrontendTables& tables) const;
  double level0_y(std::size_t i, const FrontendTables& tables) const;
};

struct StereoFeatures {
  Features left;
  Features right;
  std::vector<StereoMatch> matches;  ///< one per left keypoint
  int num_matches() const;
};

struct FrontendOptions {
  bool describe = true;        ///< orientation, blur and descriptors; off = detection only
  bool profile_stages = false; ///< synchronize between stages to time each one
};

class Frontend {
 public:
  /// Validates `settings` (SettingsError) and the size (std::invalid_argument), builds the tables
  /// and uploads them to `backend`, which must outlive the Frontend.
  Frontend(Backend& backend, const FrontendSettings& settings, int width, int height,
           FrontendOptions options = {});
  ~Frontend();
  Frontend(const Frontend&) = delete;
  Frontend& operator=(const Frontend&) = delete;

  /// Detects (and describes) features in one image of the Frontend's size.
  Features detect(const ImageView& image);
  /// Both images, then stereo matching of left against right.
  StereoFeatures detect_stereo(const ImageView& left, const ImageView& right);

  const FrontendTables& tables() const { return tables_; }
  const PyramidLayout& pyramid_layout() const { return pyramid_layout_; }
  const StageTimes& last_times() const { return times_; }
  Backend& backend() { return backend_; }

  /// Downloads the (unblurred) pyramid of the last left/single image, for drawing or debugging.
  std::vector<std::uint8_t> download_pyramid(int side = 0) const;

 private:
  struct Side;  // device state for one camera
  void run_side(Side& side, const ImageView& image);
  Features collect(Side& side);
  void check_image(const ImageView& image, const char* what) const;

  Backend& backend_;
  FrontendTables tables_;
  FrontendOptions options_;
  PyramidLayout pyramid_layout_;
  PyramidLayout response_layout_;
  std::unique_ptr<Buffer> lut_, resize_, boundaries_, pattern_;
  std::unique_ptr<Side> sides_[2];
  std::unique_ptr<Buffer> matches_;
  StageTimes times_;
};

}  // namespace porta
