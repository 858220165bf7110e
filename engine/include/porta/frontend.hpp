// The feature frontend: drives any backend through the whole pipeline of DESIGN.md §3 for one
// image or a rectified stereo pair: pyramid -> CRF -> culling -> PFA -> orientation -> blur ->
// descriptors (-> stereo match). One Frontend per settings and image size; reuse it per frame.
//
// Frames in flight: with FrontendOptions::in_flight = N > 1 the Frontend keeps N sets of device
// buffers ("slots"), each on its own queues of the backend, and `submit` returns as soon as a
// frame's work is enqueued; `collect` returns the oldest submitted frame's features. A backend with
// several queues (cuda) then overlaps the frames' transfers and kernels with each other and with
// the caller; the others run each frame in order and give the same results.
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

/// Wall-clock time of each stage of the last collected frame, in nanoseconds. Stages are only separated
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
  std::int64_t total_ns = 0;  ///< from the start of submit (or detect) to the end of collect
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

/// An image of one Frontend's size in its backend's host memory for asynchronous transfers (pinned
/// on cuda), with the pyramid's level-0 row pitch: submitting it copies nothing on the host, the
/// device reads it directly. Made by Frontend::make_input_image(); write the pixels through row().
/// It must not change until the frame that read it has been collected.
class InputImage {
 public:
  InputImage() = default;
  InputImage(InputImage&&) noexcept = default;
  InputImage& operator=(InputImage&&) noexcept = default;

  int width() const { return width_; }
  int height() const { return height_; }
  int pitch_bytes() const { return pitch_; }
  std::uint8_t* row(int y) { return buffer_->data() + static_cast<std::ptrdiff_t>(y) * pitch_; }
  const std::uint8_t* row(int y) const { return buffer_->data() + static_cast<std::ptrdiff_t>(y) * pitch_; }
  ImageView view() const { return ImageView{buffer_ ? buffer_->data() : nullptr, width_, height_, pitch_}; }
  /// Copies `image` (same size) in, row by row.
  void assign(const ImageView& image);

 private:
  friend class Frontend;
  std::unique_ptr<HostBuffer> buffer_;
  const void* owner_ = nullptr;  // the Frontend that made it
  int width_ = 0, height_ = 0, pitch_ = 0;
};

struct FrontendOptions {
  bool describe = true;        ///< orientation, blur and descriptors; off = detection only
  bool profile_stages = false; ///< synchronize between stages to time each one
  int in_flight = 1;           ///< frames submitted and not yet collected, at most (1..kMaxInFlight)
  static constexpr int kMaxInFlight = 16;
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

  /// Detects (and describes) features in one image of the Frontend's size: submit, then collect.
  /// std::logic_error when frames submitted earlier have not been collected.
  Features detect(const ImageView& image);
  /// Both images, then stereo matching of left against right: submit_stereo, then collect_stereo.
  StereoFeatures detect_stereo(const ImageView& left, const ImageView& right);

  /// Enqueues one image (copied before returning: the caller may reuse its memory at once).
  /// std::logic_error when `in_flight` frames are already pending.
  void submit(const ImageView& image);
  /// Enqueues a rectified pair (both copied before returning), as submit().
  void submit_stereo(const ImageView& left, const ImageView& right);
  /// As above without a host copy: the device reads the input images directly, so they must stay
  /// unchanged until this frame is collected. std::invalid_argument for an image this Frontend did
  /// not make.
  void submit(const InputImage& image);
  void submit_stereo(const InputImage& left, const InputImage& right);
  /// A zero-filled image of this Frontend's size for the submits above.
  InputImage make_input_image();
  /// The oldest pending frame, which must have come from submit() (std::logic_error when none is
  /// pending or it is a pair). Waits for it.
  Features collect();
  /// The oldest pending frame, which must have come from submit_stereo(); otherwise as collect().
  StereoFeatures collect_stereo();
  /// Frames submitted and not yet collected.
  int pending() const { return pending_; }
  int in_flight() const { return static_cast<int>(slots_.size()); }
  /// A queue of the backend that none of the in-flight slots uses, -1 when the backend has none to
  /// spare: other work given to it (tracking's projection matching) runs beside the frames in
  /// flight instead of waiting behind them on their queue.
  int spare_queue() const { return spare_queue_; }

  const FrontendTables& tables() const { return tables_; }
  const PyramidLayout& pyramid_layout() const { return pyramid_layout_; }
  const StageTimes& last_times() const { return times_; }
  Backend& backend() { return backend_; }

  /// Downloads the (unblurred) pyramid of the last collected left/single image, for drawing or
  /// debugging (valid until that frame's buffers are reused by a later submit).
  std::vector<std::uint8_t> download_pyramid(int side = 0) const;

 private:
  struct Side;  // device state for one camera
  struct Slot;  // one frame in flight: two sides, matches, the queues it runs on
  /// `image` (copied into the side's own input) or else `input` (read in place) is the source.
  void run_side(Slot& slot, Side& side, const ImageView* image, const InputImage* input);
  void submit_pair(const ImageView* left, const InputImage* left_input, const ImageView* right,
                   const InputImage* right_input);
  void submit_one(const ImageView* image, const InputImage* input);
  void check_input(const InputImage& input, const char* what) const;
  void enqueue_downloads(Side& side);
  Features collect_side(Slot& slot, Side& side);
  Slot& begin_submit(bool stereo);
  Slot& begin_collect(bool stereo);
  void end_collect(Slot& slot);
  void check_image(const ImageView& image, const char* what) const;

  Backend& backend_;
  FrontendTables tables_;
  FrontendOptions options_;
  PyramidLayout pyramid_layout_;
  PyramidLayout response_layout_;
  std::unique_ptr<Buffer> lut_, resize_, boundaries_, pattern_;
  PfaParams pfa_;  // PFA's parameters, made once (a frame allocates nothing for them)
  std::vector<std::unique_ptr<Slot>> slots_;
  bool downloads_at_submit_ = false;  // the backend has several queues: results travel back async
  int spare_queue_ = -1;              // spare_queue()
  int next_submit_ = 0;               // slot of the next submit
  int pending_ = 0;
  int last_collected_ = 0;
  StageTimes times_;
};

}  // namespace porta
