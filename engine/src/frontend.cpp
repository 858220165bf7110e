#include "porta/frontend.hpp"

#include <chrono>
#include <cstring>
#include <stdexcept>
#include <string>

namespace porta {

namespace {

std::int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

template <typename T>
std::unique_ptr<Buffer> upload_vector(Backend& backend, const std::vector<T>& v) {
  auto buffer = backend.allocate(v.size() * sizeof(T));
  backend.upload(*buffer, 0, v.data(), v.size() * sizeof(T));
  return buffer;
}

}  // namespace

struct Frontend::Side {
  explicit Side(Backend& backend) : keypoints(backend), descriptors(backend) {}
  std::unique_ptr<Buffer> pyramid, responses, cells, count, blurred;
  SyncBuffer<Keypoint> keypoints;
  SyncBuffer<Descriptor> descriptors;
  std::vector<std::uint8_t> staging;  // level 0 re-pitched for one upload
  int num_keypoints = 0;
};

double Features::level0_x(std::size_t i, const FrontendTables& tables) const {
  return keypoints[i].x * (tables.scales_q16[keypoints[i].level] / 65536.0);
}
double Features::level0_y(std::size_t i, const FrontendTables& tables) const {
  return keypoints[i].y * (tables.scales_q16[keypoints[i].level] / 65536.0);
}

int StereoFeatures::num_matches() const {
  int n = 0;
  for (const auto& m : matches) n += m.disparity_q8 >= 0 ? 1 : 0;
  return n;
}

Frontend::Frontend(Backend& backend, const FrontendSettings& settings, int width, int height,
                   FrontendOptions options)
    : backend_(backend), tables_(FrontendTables::build(settings, width, height)), options_(options) {
  pyramid_layout_ = PyramidLayout::make(tables_.level_sizes, 1);
  response_layout_ = PyramidLayout::make(tables_.level_sizes, 2);
  lut_ = upload_vector(backend_, tables_.fast_lut);
  resize_ = upload_vector(backend_, tables_.resize.packed.empty() ? std::vector<std::int32_t>{0}
                                                                   : tables_.resize.packed);
  boundaries_ = upload_vector(backend_, tables_.orientation_boundaries);
  pattern_ = upload_vector(backend_, tables_.orb_pattern);
  const int cells = tables_.cells.total_cells;
  for (auto& side : sides_) {
    side = std::make_unique<Side>(backend_);
    side->pyramid = backend_.allocate(static_cast<std::size_t>(pyramid_layout_.total_bytes));
    side->responses = backend_.allocate(static_cast<std::size_t>(response_layout_.total_bytes));
    side->cells = backend_.allocate(static_cast<std::size_t>(cells) * sizeof(Keypoint));
    side->count = backend_.allocate(sizeof(std::uint32_t));
    side->blurred = backend_.allocate(static_cast<std::size_t>(pyramid_layout_.total_bytes));
    side->keypoints.resize(static_cast<std::size_t>(cells));
    side->descriptors.resize(static_cast<std::size_t>(cells));
    const Plane& l0 = pyramid_layout_.levels[0];
    side->staging.assign(static_cast<std::size_t>(l0.pitch) * static_cast<std::size_t>(l0.height), 0);
  }
  matches_ = backend_.allocate(static_cast<std::size_t>(cells) * sizeof(StereoMatch));
}

Frontend::~Frontend() = default;

void Frontend::check_image(const ImageView& image, const char* what) const {
  const Plane& l0 = pyramid_layout_.levels[0];
  if (image.data == nullptr) throw std::invalid_argument(std::string(what) + " image is empty (no pixels)");
  if (image.width != l0.width || image.height != l0.height)
    throw std::invalid_argument(std::string(what) + " image is " + std::to_string(image.width) + "x" +
                                std::to_string(image.height) + " but this frontend was built for " +
                                std::to_string(l0.width) + "x" + std::to_string(l0.height));
  if (image.pitch_bytes < image.width)
    throw std::invalid_argument(std::string(what) + " image pitch " + std::to_string(image.pitch_bytes) +
                                " is smaller than its width " + std::to_string(image.width));
}

void Frontend::run_side(Side& side, const ImageView& image) {
  const bool profile = options_.profile_stages;
  std::int64_t t = now_ns();
  auto stage = [&](std::int64_t& slot) {
    if (!profile) return;
    backend_.synchronize();
    const std::int64_t t1 = now_ns();
    slot += t1 - t;
    t = t1;
  };

  const Plane& l0 = pyramid_layout_.levels[0];
  for (int y = 0; y < image.height; ++y)
    std::memcpy(side.staging.data() + static_cast<std::size_t>(y) * l0.pitch, image.row(y),
                static_cast<std::size_t>(image.width));
  backend_.upload(*side.pyramid, 0, side.staging.data(), side.staging.size());
  stage(times_.upload_ns);

  backend_.build_pyramid(*side.pyramid, pyramid_layout_, *resize_, tables_.resize.level_offset);
  stage(times_.pyramid_ns);

  const auto& s = tables_.settings;
  backend_.fast_crf(*side.pyramid, pyramid_layout_, *lut_, *side.responses, response_layout_,
                    FastParams{s.fast_threshold, s.edge});
  stage(times_.fast_ns);

  backend_.cull_cells(*side.responses, response_layout_, tables_.cells, *side.cells);
  stage(times_.cull_ns);

  if (s.pfa) {
    backend_.pfa_filter(*side.cells, tables_.cells,
                        PfaParams{tables_.scales_q16, l0.width, l0.height, s.pfa_window});
  }
  const DeviceList list{&side.keypoints.device_write(), side.count.get(), 0, tables_.cells.total_cells};
  backend_.compact_keypoints(*side.cells, tables_.cells.total_cells, list);
  stage(times_.pfa_ns);

  if (!options_.describe) return;
  backend_.orient(*side.pyramid, pyramid_layout_, list, tables_.umax, *boundaries_, s.orientation_bins);
  stage(times_.orient_ns);
  backend_.blur(*side.pyramid, pyramid_layout_, *side.blurred, tables_.blur_taps);
  stage(times_.blur_ns);
  backend_.orb_describe(*side.blurred, pyramid_layout_, list, *pattern_, side.descriptors.device_write());
  stage(times_.describe_ns);
}

Features Frontend::collect(Side& side) {
  const std::int64_t t = now_ns();
  std::uint32_t count = 0;
  backend_.download(*side.count, 0, &count, sizeof(count));
  side.num_keypoints = static_cast<int>(count);
  Features f;
  side.keypoints.resize(count);
  const Keypoint* kp = side.keypoints.host_read();
  f.keypoints.assign(kp, kp + count);
  if (options_.describe) {
    side.descriptors.resize(count);
    const Descriptor* d = side.descriptors.host_read();
    f.descriptors.assign(d, d + count);
  }
  // Restore the full capacity for the next frame's device writes.
  side.keypoints.resize(static_cast<std::size_t>(tables_.cells.total_cells));
  side.descriptors.resize(static_cast<std::size_t>(tables_.cells.total_cells));
  f.keypoints_per_level.assign(static_cast<std::size_t>(tables_.settings.levels), 0);
  for (const auto& k : f.keypoints) ++f.keypoints_per_level[k.level];
  times_.download_ns += now_ns() - t;
  return f;
}

Features Frontend::detect(const ImageView& image) {
  check_image(image, "input");
  times_ = {};
  const std::int64_t t0 = now_ns();
  run_side(*sides_[0], image);
  Features f = collect(*sides_[0]);
  times_.total_ns = now_ns() - t0;
  return f;
}

StereoFeatures Frontend::detect_stereo(const ImageView& left, const ImageView& right) {
  if (!options_.describe) throw std::logic_error("Frontend: stereo matching needs descriptors (describe = true)");
  check_image(left, "left");
  check_image(right, "right");
  times_ = {};
  const std::int64_t t0 = now_ns();
  // The two images are independent until stereo matching: one queue each, so that a backend with
  // several queues overlaps them (stage profiling synchronises after each stage, serialising them).
  backend_.use_queue(0);
  run_side(*sides_[0], left);
  backend_.use_queue(1);
  run_side(*sides_[1], right);
  backend_.use_queue(0);
  backend_.join_queues();
  StereoFeatures out;
  out.left = collect(*sides_[0]);
  out.right = collect(*sides_[1]);

  const std::int64_t ts = now_ns();
  const auto& s = tables_.settings;
  StereoParams params{tables_.scales_q16, tables_.stereo_row_radius_q8, s.stereo_min_disparity * 256,
                      s.stereo_max_disparity * 256, s.stereo_max_hamming};
  const int capacity = tables_.cells.total_cells;
  const ConstDeviceList lk{DeviceList{&sides_[0]->keypoints.device_write(), sides_[0]->count.get(), 0, capacity}};
  const ConstDeviceList rk{DeviceList{&sides_[1]->keypoints.device_write(), sides_[1]->count.get(), 0, capacity}};
  backend_.stereo_match(*sides_[0]->pyramid, *sides_[1]->pyramid, pyramid_layout_, lk,
                        sides_[0]->descriptors.device_read(), rk, sides_[1]->descriptors.device_read(), params,
                        *matches_);
  out.matches.resize(out.left.keypoints.size());
  backend_.download(*matches_, 0, out.matches.data(), out.matches.size() * sizeof(StereoMatch));
  times_.stereo_ns += now_ns() - ts;
  times_.total_ns = now_ns() - t0;
  return out;
}

std::vector<std::uint8_t> Frontend::download_pyramid(int side) const {
  std::vector<std::uint8_t> out(static_cast<std::size_t>(pyramid_layout_.total_bytes));
  backend_.download(*sides_[side == 0 ? 0 : 1]->pyramid, 0, out.data(), out.size());
  return out;
}

}  // namespace porta
