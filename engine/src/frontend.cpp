#include "porta/frontend.hpp"

#include <algorithm>
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

// Device state of one camera in one slot. The keypoint buffer holds the list's records, then its
// count (at `count_offset`), so that one transfer brings both back.
struct Frontend::Side {
  std::unique_ptr<Buffer> pyramid, responses, cells, blurred, keypoints, descriptors;
  std::unique_ptr<HostBuffer> input;   // level 0 at the pyramid's pitch: the upload's source
  std::unique_ptr<HostBuffer> output;  // the keypoint buffer, then the descriptors, as downloaded
  std::size_t count_offset = 0;
  std::size_t descriptors_at = 0;  // in `output`
  int capacity = 0;

  DeviceList list() {
    return DeviceList{keypoints.get(), keypoints.get(), static_cast<std::int64_t>(count_offset), capacity};
  }
  std::uint32_t downloaded_count() const {
    std::uint32_t n = 0;
    std::memcpy(&n, output->data() + count_offset, sizeof(n));
    return std::min<std::uint32_t>(n, static_cast<std::uint32_t>(capacity));
  }
};

struct Frontend::Slot {
  Side sides[2];
  std::unique_ptr<Buffer> matches;
  std::unique_ptr<HostBuffer> match_output;
  int queues[2] = {0, 0};
  bool stereo = false;
  std::int64_t submitted_ns = 0;
  StageTimes times;
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
  if (options_.in_flight < 1 || options_.in_flight > FrontendOptions::kMaxInFlight)
    throw std::invalid_argument("Frontend: in_flight = " + std::to_string(options_.in_flight) +
                                " is outside [1, " + std::to_string(FrontendOptions::kMaxInFlight) +
                                "] (frames submitted and not yet collected)");
  pyramid_layout_ = PyramidLayout::make(tables_.level_sizes, 1);
  response_layout_ = PyramidLayout::make(tables_.level_sizes, 2);
  lut_ = upload_vector(backend_, tables_.fast_lut);
  resize_ = upload_vector(backend_, tables_.resize.packed.empty() ? std::vector<std::int32_t>{0}
                                                                   : tables_.resize.packed);
  boundaries_ = upload_vector(backend_, tables_.orientation_boundaries);
  pattern_ = upload_vector(backend_, tables_.orb_pattern);
  pfa_ = PfaParams{tables_.scales_q16, pyramid_layout_.levels[0].width, pyramid_layout_.levels[0].height,
                   tables_.settings.pfa_window};
  const int queues = std::max(backend_.queue_count(), 1);
  downloads_at_submit_ = queues > 1;
  // The slots take queues 0 .. 2 in_flight - 1 (modulo the count): the next one, if any, is free.
  if (queues > 2 * options_.in_flight) spare_queue_ = 2 * options_.in_flight;
  const int cells = tables_.cells.total_cells;
  const auto cells_z = static_cast<std::size_t>(cells);
  const Plane& l0 = pyramid_layout_.levels[0];
  for (int s = 0; s < options_.in_flight; ++s) {
    auto slot = std::make_unique<Slot>();
    // Each slot on queues of its own where the backend has enough; both sides on one otherwise.
    slot->queues[0] = (2 * s) % queues;
    slot->queues[1] = (2 * s + 1) % queues;
    for (Side& side : slot->sides) {
      side.capacity = cells;
      side.pyramid = backend_.allocate(static_cast<std::size_t>(pyramid_layout_.total_bytes));
      side.responses = backend_.allocate(static_cast<std::size_t>(response_layout_.total_bytes));
      side.cells = backend_.allocate(cells_z * sizeof(Keypoint));
      side.blurred = backend_.allocate(static_cast<std::size_t>(pyramid_layout_.total_bytes));
      side.count_offset = cells_z * sizeof(Keypoint);
      side.keypoints = backend_.allocate(side.count_offset + sizeof(std::uint32_t));
      side.descriptors = backend_.allocate(cells_z * sizeof(Descriptor));
      side.input = backend_.allocate_host(static_cast<std::size_t>(l0.pitch) * static_cast<std::size_t>(l0.height));
      side.descriptors_at = (side.keypoints->size_bytes() + 63) / 64 * 64;
      side.output = backend_.allocate_host(side.descriptors_at + side.descriptors->size_bytes());
    }
    slot->matches = backend_.allocate(cells_z * sizeof(StereoMatch));
    slot->match_output = backend_.allocate_host(slot->matches->size_bytes());
    slots_.push_back(std::move(slot));
  }
  // The tables are read by every queue.
  backend_.synchronize();
}

Frontend::~Frontend() {
  // Work still in flight writes into the slots' memory: let it finish first. Errors are the
  // caller's to see through collect(); a destructor cannot report them.
  try {
    if (pending_ > 0) backend_.synchronize();
  } catch (...) {
  }
}

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

void InputImage::assign(const ImageView& image) {
  if (image.data == nullptr || image.width != width_ || image.height != height_)
    throw std::invalid_argument("InputImage::assign: the image is " + std::to_string(image.width) + "x" +
                                std::to_string(image.height) + ", this input image " + std::to_string(width_) + "x" +
                                std::to_string(height_));
  for (int y = 0; y < height_; ++y) std::memcpy(row(y), image.row(y), static_cast<std::size_t>(width_));
}

InputImage Frontend::make_input_image() {
  const Plane& l0 = pyramid_layout_.levels[0];
  InputImage out;
  out.buffer_ = backend_.allocate_host(static_cast<std::size_t>(l0.pitch) * static_cast<std::size_t>(l0.height));
  out.owner_ = this;
  out.width_ = l0.width;
  out.height_ = l0.height;
  out.pitch_ = l0.pitch;
  return out;
}

void Frontend::check_input(const InputImage& input, const char* what) const {
  if (input.owner_ != this || !input.buffer_)
    throw std::invalid_argument(std::string(what) +
                                " input image was not made by this Frontend's make_input_image() (or was moved from)");
}

void Frontend::run_side(Slot& slot, Side& side, const ImageView* image, const InputImage* input) {
  const bool profile = options_.profile_stages;
  StageTimes& times = slot.times;
  std::int64_t t = now_ns();
  auto stage = [&](std::int64_t& slot_ns) {
    if (!profile) return;
    backend_.synchronize();
    const std::int64_t t1 = now_ns();
    slot_ns += t1 - t;
    t = t1;
  };

  const Plane& l0 = pyramid_layout_.levels[0];
  if (input != nullptr) {
    backend_.upload_async(*side.pyramid, 0, *input->buffer_, 0, input->buffer_->size_bytes());
  } else {
    std::uint8_t* to = side.input->data();
    for (int y = 0; y < image->height; ++y)
      std::memcpy(to + static_cast<std::size_t>(y) * l0.pitch, image->row(y), static_cast<std::size_t>(image->width));
    backend_.upload_async(*side.pyramid, 0, *side.input, 0, side.input->size_bytes());
  }
  stage(times.upload_ns);

  backend_.build_pyramid(*side.pyramid, pyramid_layout_, *resize_, tables_.resize.level_offset);
  stage(times.pyramid_ns);
  // The blur needs the pyramid only: issued before detection, a backend may run it beside it.
  if (options_.describe) {
    backend_.blur(*side.pyramid, pyramid_layout_, *side.blurred, tables_.blur_taps);
    stage(times.blur_ns);
  }

  const auto& s = tables_.settings;
  const FastParams fast{s.fast_threshold, s.edge};
  const DeviceList list = side.list();
  if (!profile) {
    // Detection to the keypoint list in one call: a backend may run it in fewer launches.
    backend_.detect_keypoints(*side.pyramid, pyramid_layout_, *lut_, *side.responses, response_layout_, fast,
                              tables_.cells, *side.cells, s.pfa ? &pfa_ : nullptr, list);
  } else {
    backend_.fast_crf(*side.pyramid, pyramid_layout_, *lut_, *side.responses, response_layout_, fast);
    stage(times.fast_ns);
    backend_.cull_cells(*side.responses, response_layout_, tables_.cells, *side.cells);
    stage(times.cull_ns);
    if (s.pfa) backend_.pfa_filter(*side.cells, tables_.cells, pfa_);
    backend_.compact_keypoints(*side.cells, tables_.cells.total_cells, list);
    stage(times.pfa_ns);
  }

  if (!options_.describe) return;
  backend_.orient(*side.pyramid, pyramid_layout_, list, tables_.umax, *boundaries_, s.orientation_bins);
  stage(times.orient_ns);
  backend_.orb_describe(*side.blurred, pyramid_layout_, list, *pattern_, *side.descriptors);
  stage(times.describe_ns);
}

// Asynchronous path: the whole keypoint buffer (records and count) and every descriptor slot travel
// back with the frame's work, as the host cannot know the count before the frame has run.
void Frontend::enqueue_downloads(Side& side) {
  backend_.download_async(*side.keypoints, 0, *side.output, 0, side.keypoints->size_bytes());
  if (options_.describe)
    backend_.download_async(*side.descriptors, 0, *side.output, side.descriptors_at, side.descriptors->size_bytes());
}

Features Frontend::collect_side(Slot& slot, Side& side) {
  const std::int64_t t = now_ns();
  std::uint32_t count = 0;
  if (downloads_at_submit_) {
    count = side.downloaded_count();
  } else {
    // In-order backend: the count first, then only the records in use.
    backend_.download(*side.keypoints, side.count_offset, side.output->data() + side.count_offset, sizeof(count));
    count = side.downloaded_count();
    backend_.download(*side.keypoints, 0, side.output->data(), count * sizeof(Keypoint));
    if (options_.describe)
      backend_.download(*side.descriptors, 0, side.output->data() + side.descriptors_at, count * sizeof(Descriptor));
  }
  Features f;
  const auto* kp = reinterpret_cast<const Keypoint*>(side.output->data());
  f.keypoints.assign(kp, kp + count);
  if (options_.describe) {
    const auto* d = reinterpret_cast<const Descriptor*>(side.output->data() + side.descriptors_at);
    f.descriptors.assign(d, d + count);
  }
  f.keypoints_per_level.assign(static_cast<std::size_t>(tables_.settings.levels), 0);
  for (const auto& k : f.keypoints) ++f.keypoints_per_level[k.level];
  slot.times.download_ns += now_ns() - t;
  return f;
}

Frontend::Slot& Frontend::begin_submit(bool stereo) {
  if (stereo && !options_.describe)
    throw std::logic_error("Frontend: stereo matching needs descriptors (describe = true)");
  if (pending_ >= in_flight())
    throw std::logic_error("Frontend: " + std::to_string(pending_) + " frame" + (pending_ == 1 ? " is" : "s are") +
                           " already in flight (in_flight = " + std::to_string(in_flight()) +
                           "); collect one before submitting another");
  Slot& slot = *slots_[static_cast<std::size_t>(next_submit_)];
  slot.stereo = stereo;
  slot.times = {};
  slot.submitted_ns = now_ns();
  return slot;
}

Frontend::Slot& Frontend::begin_collect(bool stereo) {
  const char* const want = stereo ? "collect_stereo" : "collect";
  if (pending_ == 0)
    throw std::logic_error(std::string("Frontend: ") + want + "() with no frame in flight (submit one first)");
  const int oldest = (next_submit_ - pending_ + in_flight()) % in_flight();
  Slot& slot = *slots_[static_cast<std::size_t>(oldest)];
  if (slot.stereo != stereo)
    throw std::logic_error(std::string("Frontend: ") + want + "(): the oldest frame in flight is " +
                           (slot.stereo ? "a stereo pair (use collect_stereo)" : "a single image (use collect)"));
  // Whatever happens below, the frame leaves the queue: an error is reported once.
  last_collected_ = oldest;
  --pending_;
  backend_.finish_queue(slot.queues[0]);
  if (stereo && slot.queues[1] != slot.queues[0]) backend_.finish_queue(slot.queues[1]);
  return slot;
}

void Frontend::end_collect(Slot& slot) {
  slot.times.total_ns = now_ns() - slot.submitted_ns;
  times_ = slot.times;
}

void Frontend::submit(const ImageView& image) {
  check_image(image, "input");
  submit_one(&image, nullptr);
}

void Frontend::submit(const InputImage& image) {
  check_input(image, "the");
  submit_one(nullptr, &image);
}

void Frontend::submit_stereo(const ImageView& left, const ImageView& right) {
  check_image(left, "left");
  check_image(right, "right");
  submit_pair(&left, nullptr, &right, nullptr);
}

void Frontend::submit_stereo(const InputImage& left, const InputImage& right) {
  check_input(left, "left");
  check_input(right, "right");
  submit_pair(nullptr, &left, nullptr, &right);
}

void Frontend::submit_one(const ImageView* image, const InputImage* input) {
  Slot& slot = begin_submit(false);
  backend_.use_queue(slot.queues[0]);
  run_side(slot, slot.sides[0], image, input);
  if (downloads_at_submit_) enqueue_downloads(slot.sides[0]);
  backend_.flush();  // the frame runs while the caller works
  next_submit_ = (next_submit_ + 1) % in_flight();
  ++pending_;
}

void Frontend::submit_pair(const ImageView* left, const InputImage* left_input, const ImageView* right,
                           const InputImage* right_input) {
  Slot& slot = begin_submit(true);
  // The two images are independent until stereo matching: one queue each, so that a backend with
  // several queues overlaps them (stage profiling synchronises after each stage, serialising them).
  backend_.use_queue(slot.queues[1]);
  run_side(slot, slot.sides[1], right, right_input);
  if (downloads_at_submit_) enqueue_downloads(slot.sides[1]);
  backend_.use_queue(slot.queues[0]);
  run_side(slot, slot.sides[0], left, left_input);
  if (slot.queues[1] != slot.queues[0]) backend_.queue_wait(slot.queues[1]);

  const std::int64_t ts = now_ns();
  const auto& s = tables_.settings;
  StereoParams params{tables_.scales_q16, tables_.stereo_row_radius_q8, s.stereo_min_disparity * 256,
                      s.stereo_max_disparity * 256, s.stereo_max_hamming};
  Side& l = slot.sides[0];
  Side& r = slot.sides[1];
  backend_.stereo_match(*l.pyramid, *r.pyramid, pyramid_layout_, l.list(), *l.descriptors, r.list(), *r.descriptors,
                        params, *slot.matches);
  if (downloads_at_submit_) {
    enqueue_downloads(l);
    backend_.download_async(*slot.matches, 0, *slot.match_output, 0, slot.matches->size_bytes());
  }
  backend_.flush();  // the frame runs while the caller works
  slot.times.stereo_ns += now_ns() - ts;
  next_submit_ = (next_submit_ + 1) % in_flight();
  ++pending_;
}

Features Frontend::collect() {
  Slot& slot = begin_collect(false);
  Features f = collect_side(slot, slot.sides[0]);
  end_collect(slot);
  return f;
}

StereoFeatures Frontend::collect_stereo() {
  Slot& slot = begin_collect(true);
  StereoFeatures out;
  out.left = collect_side(slot, slot.sides[0]);
  out.right = collect_side(slot, slot.sides[1]);
  const std::int64_t ts = now_ns();
  out.matches.resize(out.left.keypoints.size());
  const std::size_t bytes = out.matches.size() * sizeof(StereoMatch);
  if (!downloads_at_submit_) backend_.download(*slot.matches, 0, slot.match_output->data(), bytes);
  if (bytes > 0) std::memcpy(out.matches.data(), slot.match_output->data(), bytes);
  slot.times.stereo_ns += now_ns() - ts;
  end_collect(slot);
  return out;
}

Features Frontend::detect(const ImageView& image) {
  if (pending_ > 0)
    throw std::logic_error("Frontend: detect() while " + std::to_string(pending_) +
                           " submitted frame(s) wait to be collected");
  submit(image);
  return collect();
}

StereoFeatures Frontend::detect_stereo(const ImageView& left, const ImageView& right) {
  if (pending_ > 0)
    throw std::logic_error("Frontend: detect_stereo() while " + std::to_string(pending_) +
                           " submitted frame(s) wait to be collected");
  submit_stereo(left, right);
  return collect_stereo();
}

std::vector<std::uint8_t> Frontend::download_pyramid(int side) const {
  std::vector<std::uint8_t> out(static_cast<std::size_t>(pyramid_layout_.total_bytes));
  const Slot& slot = *slots_[static_cast<std::size_t>(last_collected_)];
  backend_.download(*slot.sides[side == 0 ? 0 : 1].pyramid, 0, out.data(), out.size());
  return out;
}

}  // namespace porta
