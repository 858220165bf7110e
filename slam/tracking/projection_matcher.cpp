// Projection matching on a backend or on the host; see projection_matcher.hpp.
#include "porta/slam/projection_matcher.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "porta/slam/map.hpp"
#include "porta/sync_buffer.hpp"

namespace porta::slam {

std::vector<Keypoint> kernel_keypoints(const FrameFeatures& features,
                                       const std::vector<std::int32_t>& scales_q16) {
  if (features.keypoints.size() == features.size()) return features.keypoints;
  std::vector<Keypoint> out(features.size());
  for (std::size_t i = 0; i < features.size(); ++i) {
    const int level = features.level[i];
    if (static_cast<std::size_t>(level) >= scales_q16.size()) {
      throw std::invalid_argument("tracking: feature " + std::to_string(i) + " has pyramid level " +
                                  std::to_string(level) + " but the frontend has " +
                                  std::to_string(scales_q16.size()) + " levels");
    }
    const double to_level = 65536.0 / scales_q16[static_cast<std::size_t>(level)];
    auto coordinate = [&](float c) {
      return static_cast<std::uint16_t>(std::clamp(std::lround(c * to_level), 0L, 65535L));
    };
    out[i].x = coordinate(features.uv[i].x());
    out[i].y = coordinate(features.uv[i].y());
    out[i].response = 1;
    out[i].level = static_cast<std::uint8_t>(level);
  }
  return out;
}

struct ProjectionMatcher::DeviceSide {
  explicit DeviceSide(Backend& b)
      : keypoints(b), keypoint_descriptors(b), count(b), queries(b), query_descriptors(b), results(b) {}
  SyncBuffer<Keypoint> keypoints;
  SyncBuffer<Descriptor> keypoint_descriptors;
  SyncBuffer<std::uint32_t> count;
  SyncBuffer<ProjectionQuery> queries;
  SyncBuffer<Descriptor> query_descriptors;
  SyncBuffer<ProjectionResult> results;
  int num_keypoints = 0;
};

ProjectionMatcher::ProjectionMatcher(Backend* backend, std::vector<std::int32_t> scales_q16, int queue)
    : backend_(backend), scales_q16_(std::move(scales_q16)), queue_(queue) {
  if (backend_ == nullptr) return;
  if (queue_ >= 0 && queue_ >= backend_->queue_count()) {
    throw BackendError(backend_->name() + ": projection matching on queue " + std::to_string(queue_) +
                       ", but the backend has queues 0 to " + std::to_string(backend_->queue_count() - 1));
  }
  device_ = std::make_unique<DeviceSide>(*backend_);
}

ProjectionMatcher::~ProjectionMatcher() = default;

void ProjectionMatcher::set_frame(std::vector<Keypoint> keypoints,
                                  const std::vector<Descriptor>& descriptors) {
  if (keypoints.size() != descriptors.size()) {
    throw std::invalid_argument("ProjectionMatcher::set_frame: " + std::to_string(keypoints.size()) +
                                " keypoints but " + std::to_string(descriptors.size()) + " descriptors");
  }
  if (device_) {
    const std::size_t n = keypoints.size();
    device_->num_keypoints = static_cast<int>(n);
    device_->keypoints.resize(n);
    device_->keypoint_descriptors.resize(n);
    std::copy(keypoints.begin(), keypoints.end(), device_->keypoints.host_write());
    std::copy(descriptors.begin(), descriptors.end(), device_->keypoint_descriptors.host_write());
    device_->count.resize(1);
    *device_->count.host_write() = static_cast<std::uint32_t>(n);
    return;
  }
  descriptors_ = descriptors;
  by_row_.clear();
  by_row_.reserve(keypoints.size());
  for (std::size_t k = 0; k < keypoints.size(); ++k) {
    const Keypoint& kp = keypoints[k];
    if (kp.level >= scales_q16_.size()) continue;  // as the kernel: no scale, never a candidate
    const std::int32_t s = scales_q16_[kp.level];
    by_row_.push_back({level0_q8(kp.y, s), level0_q8(kp.x, s), static_cast<int>(k), kp.level});
  }
  std::sort(by_row_.begin(), by_row_.end(), [](const Placed& a, const Placed& b) {
    return a.v_q8 != b.v_q8 ? a.v_q8 < b.v_q8 : a.index < b.index;
  });
}

std::vector<ProjectionResult> ProjectionMatcher::match(const std::vector<ProjectionQuery>& queries,
                                                       const std::vector<Descriptor>& query_descriptors) {
  if (queries.size() != query_descriptors.size()) {
    throw std::invalid_argument("ProjectionMatcher::match: " + std::to_string(queries.size()) +
                                " queries but " + std::to_string(query_descriptors.size()) + " descriptors");
  }
  if (queries.empty()) return {};
  if (!device_) return match_on_host(queries, query_descriptors);

  if (queue_ >= 0) backend_->use_queue(queue_);
  DeviceSide& d = *device_;
  const std::size_t n = queries.size();
  d.queries.resize(n);
  d.query_descriptors.resize(n);
  d.results.resize(n);
  std::copy(queries.begin(), queries.end(), d.queries.host_write());
  std::copy(query_descriptors.begin(), query_descriptors.end(), d.query_descriptors.host_write());
  ConstDeviceList list;
  list.items = &d.keypoints.device_read();
  list.count = &d.count.device_read();
  list.count_offset_bytes = 0;
  list.capacity = d.num_keypoints;
  const Buffer& keypoint_descriptors = d.keypoint_descriptors.device_read();
  const Buffer& query_buffer = d.queries.device_read();
  const Buffer& query_descriptor_buffer = d.query_descriptors.device_read();
  backend_->projection_match(list, keypoint_descriptors, query_buffer, query_descriptor_buffer,
                             static_cast<int>(n), scales_q16_, d.results.device_write());
  const ProjectionResult* r = d.results.host_read();
  return std::vector<ProjectionResult>(r, r + n);
}

// The host definition of §3.10, written independently of any backend: the window is a closed
// square in 1/256 px, the level range inclusive, ties go to the lower keypoint index.
std::vector<ProjectionResult> ProjectionMatcher::match_on_host(
    const std::vector<ProjectionQuery>& queries, const std::vector<Descriptor>& query_descriptors) const {
  std::vector<ProjectionResult> out(queries.size());
  for (std::size_t i = 0; i < queries.size(); ++i) {
    const ProjectionQuery& q = queries[i];
    const std::int64_t v_lo = static_cast<std::int64_t>(q.v_q8) - q.radius_q8;
    const std::int64_t v_hi = static_cast<std::int64_t>(q.v_q8) + q.radius_q8;
    auto it = std::lower_bound(by_row_.begin(), by_row_.end(), v_lo,
                               [](const Placed& p, std::int64_t v) { return p.v_q8 < v; });
    ProjectionResult r;
    for (; it != by_row_.end() && it->v_q8 <= v_hi; ++it) {
      if (it->level < q.min_level || it->level > q.max_level) continue;
      if (std::abs(static_cast<std::int64_t>(it->u_q8) - q.u_q8) > q.radius_q8) continue;
      const int distance =
          hamming_distance(query_descriptors[i], descriptors_[static_cast<std::size_t>(it->index)]);
      const bool better = r.best_index < 0 || distance < r.best_distance ||
                          (distance == r.best_distance && it->index < r.best_index);
      if (better) {
        r.second_distance = std::min(r.second_distance, r.best_distance);
        r.best_distance = distance;
        r.best_index = it->index;
      } else {
        r.second_distance = std::min(r.second_distance, distance);
      }
    }
    out[i] = r;
  }
  return out;
}

}  // namespace porta::slam
