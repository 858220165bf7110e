#include "porta/slam/map.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>

namespace porta::slam {

// ---- MapPoint -------------------------------------------------------------------------------------

MapPoint::MapPoint(std::uint64_t id_in, const Eigen::Vector3d& position_in, KeyFrame* reference_in,
                   std::uint64_t first_frame_id_in)
    : position(position_in),
      id(id_in),
      reference(reference_in),
      first_keyframe_id(reference_in ? reference_in->id : 0),
      first_frame_id(first_frame_id_in) {}

MapPoint::MapPoint(std::uint64_t id_in, const Eigen::Vector3d& position_in, KeyFrame* reference_in,
                   std::uint64_t first_keyframe_id_in, std::uint64_t first_frame_id_in)
    : position(position_in),
      id(id_in),
      reference(reference_in),
      first_keyframe_id(first_keyframe_id_in),
      first_frame_id(first_frame_id_in) {}

int MapPoint::num_observations() const {
  int n = 0;
  for (const auto& [keyframe, feature] : observations) n += keyframe->features->has_depth(feature) ? 2 : 1;
  return n;
}

void MapPoint::update_descriptor() {
  // Up to kSmall observations (nearly every point) on the stack: this runs for each point a
  // keyframe links or creates, under the map lock.
  constexpr std::size_t kSmall = 32;
  std::array<const Descriptor*, kSmall> small_candidates;
  std::vector<const Descriptor*> large_candidates;
  const bool small = observations.size() <= kSmall;
  if (!small) large_candidates.resize(observations.size());
  const Descriptor** candidates = small ? small_candidates.data() : large_candidates.data();
  std::size_t n = 0;
  for (const auto& [keyframe, feature] : observations) {
    if (!keyframe->bad) candidates[n++] = &keyframe->features->descriptors[feature];
  }
  if (n == 0) return;
  std::array<int, kSmall * kSmall> small_distances;
  std::array<int, kSmall> small_row;
  std::vector<int> large_distances, large_row;
  if (!small) {
    large_distances.resize(n * n);
    large_row.resize(n);
  }
  int* distances = small ? small_distances.data() : large_distances.data();
  int* row = small ? small_row.data() : large_row.data();
  for (std::size_t i = 0; i < n; ++i) {
    distances[i * n + i] = 0;
    for (std::size_t j = i + 1; j < n; ++j) {
      distances[i * n + j] = distances[j * n + i] = hamming_distance(*candidates[i], *candidates[j]);
    }
  }
  int best_median = std::numeric_limits<int>::max();
  std::size_t best = 0;
  for (std::size_t i = 0; i < n; ++i) {
    std::copy(distances + i * n, distances + (i + 1) * n, row);
    std::nth_element(row, row + (n - 1) / 2, row + n);
    const int median = row[(n - 1) / 2];
    if (median < best_median) {  // ties keep the earliest keyframe: deterministic
      best_median = median;
      best = i;
    }
  }
  descriptor = *candidates[best];
}

void MapPoint::update_normal_and_depth(const ScalePyramid& pyramid) {
  if (observations.empty() || reference == nullptr) return;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  int count = 0;
  for (const auto& [keyframe, feature] : observations) {
    const Eigen::Vector3d ray = position - keyframe->center();
    if (ray.norm() > 0.0) {
      sum += ray.normalized();
      ++count;
    }
  }
  if (count > 0 && sum.norm() > 0.0) normal = sum.normalized();
  const auto it = observations.find(reference);
  if (it == observations.end()) return;
  const double distance = (position - reference->center()).norm();
  const int level = reference->features->level[it->second];
  const int top = std::max(0, pyramid.levels - 1);
  max_distance = distance * pyramid.scale[std::min(level, top)];
  min_distance = max_distance / pyramid.scale[top];
}

int MapPoint::predict_level(double distance, const ScalePyramid& pyramid) const {
  if (!(distance > 0.0) || !(max_distance > 0.0)) return 0;
  const double ratio = max_distance / distance;
  const int level = static_cast<int>(std::ceil(std::log(ratio) / std::log(pyramid.scale_factor)));
  return std::clamp(level, 0, pyramid.levels - 1);
}

// ---- KeyFrame -------------------------------------------------------------------------------------

KeyFrame::KeyFrame(std::uint64_t id_in, const Frame& frame)
    : id(id_in),
      frame_id(frame.id),
      time_s(frame.time_s),
      features(frame.features),
      grid(frame.grid),
      T_cw(frame.T_cw),
      points(frame.features->size(), nullptr) {}

int KeyFrame::tracked_points(int min_observations) const {
  int n = 0;
  for (const MapPoint* point : points) {
    if (point == nullptr || point->bad) continue;
    // num_observations() >= min_observations, counting only as far as needed (tracking asks this
    // of its reference keyframe every frame).
    int seen = 0;
    for (auto it = point->observations.begin(); it != point->observations.end() && seen < min_observations; ++it) {
      seen += it->first->features->has_depth(it->second) ? 2 : 1;
    }
    if (seen >= min_observations) ++n;
  }
  return n;
}

void KeyFrame::update_connections(int min_weight) {
  // Thousands of increments over a few dozen keyframes: a sorted vector (by id, as a ById map
  // iterates), not a tree.
  IdMap<KeyFrame, int> counts;
  for (const MapPoint* point : points) {
    if (point == nullptr || point->bad) continue;
    for (const auto& [other, feature] : point->observations) {
      if (other != this && !other->bad) ++counts[other];
    }
  }
  if (counts.empty()) return;
  IdMap<KeyFrame, int> kept;
  KeyFrame* best = nullptr;
  int best_weight = 0;
  for (const auto& [other, weight] : counts) {
    if (weight > best_weight) {
      best = other;
      best_weight = weight;
    }
    if (weight >= min_weight) kept[other] = weight;
  }
  if (kept.empty()) kept[best] = best_weight;
  for (const auto& [other, weight] : connections) {
    if (kept.find(other) == kept.end()) other->connections.erase(this);
  }
  connections = kept;
  for (const auto& [other, weight] : connections) other->connections[this] = weight;
  if (parent == nullptr && id != 0) {
    parent = best;
    best->children[this] = 0;
  }
}

namespace {

std::vector<std::pair<KeyFrame*, int>> by_weight(const IdMap<KeyFrame, int>& connections) {
  std::vector<std::pair<KeyFrame*, int>> sorted(connections.begin(), connections.end());
  std::stable_sort(sorted.begin(), sorted.end(), [](const auto& a, const auto& b) { return a.second > b.second; });
  return sorted;
}

}  // namespace

std::vector<KeyFrame*> KeyFrame::best_covisibles(std::size_t n) const {
  // The good neighbours, then only the best n of them ordered (tracking asks this of every local
  // keyframe on every frame): by decreasing weight, ties by id, as by_weight() orders them.
  std::vector<std::pair<KeyFrame*, int>> good;
  good.reserve(connections.size());
  for (const auto& [keyframe, weight] : connections) {
    if (!keyframe->bad) good.emplace_back(keyframe, weight);
  }
  const std::size_t kept = std::min(n, good.size());
  std::partial_sort(good.begin(), good.begin() + static_cast<std::ptrdiff_t>(kept), good.end(),
                    [](const auto& a, const auto& b) {
                      return a.second != b.second ? a.second > b.second : a.first->id < b.first->id;
                    });
  std::vector<KeyFrame*> out(kept);
  for (std::size_t i = 0; i < kept; ++i) out[i] = good[i].first;
  return out;
}

std::vector<KeyFrame*> KeyFrame::covisibles_with_weight(int min_weight) const {
  std::vector<KeyFrame*> out;
  for (const auto& [keyframe, weight] : by_weight(connections)) {
    if (weight < min_weight) break;
    if (!keyframe->bad) out.push_back(keyframe);
  }
  return out;
}

void KeyFrame::erase_connection(KeyFrame* other) { connections.erase(other); }

// ---- Map ------------------------------------------------------------------------------------------

std::unique_lock<MapMutex> Map::lock_first() {
  first_waiters_.fetch_add(1);
  std::unique_lock lock(mutex);
  first_waiters_.fetch_sub(1);
  return lock;
}

bool Map::yield_to_waiters(std::unique_lock<MapMutex>& lock) {
  if (first_waiters_.load() == 0) return false;
  lock.unlock();
  // std::mutex is not fair: re-locking at once would often win against the waiter it woke. Wait
  // until it holds the lock (it stops counting itself once it has it), then queue behind it.
  while (first_waiters_.load() > 0) std::this_thread::yield();
  lock.lock();
  return true;
}

KeyFrame* Map::add_keyframe(const Frame& frame) {
  keyframes_.push_back(std::make_unique<KeyFrame>(keyframes_.size(), frame));
  return keyframes_.back().get();
}

MapPoint* Map::add_point(const Eigen::Vector3d& position, KeyFrame* reference, std::uint64_t frame_id) {
  points_.push_back(std::make_unique<MapPoint>(points_.size(), position, reference, frame_id));
  return points_.back().get();
}

namespace {

/// The empty slot at `id` (grown as needed), or std::invalid_argument naming what holds it.
template <class T>
std::unique_ptr<T>& free_slot(std::vector<std::unique_ptr<T>>& slots, std::uint64_t id, const char* what) {
  if (id >= slots.size()) slots.resize(static_cast<std::size_t>(id) + 1);
  if (slots[id] != nullptr) {
    throw std::invalid_argument(std::string("Map: cannot restore ") + what + " " + std::to_string(id) +
                                ": the id is taken");
  }
  return slots[id];
}

}  // namespace

KeyFrame* Map::restore_keyframe(std::uint64_t id, const Frame& frame) {
  std::unique_ptr<KeyFrame>& slot = free_slot(keyframes_, id, "keyframe");
  slot = std::make_unique<KeyFrame>(id, frame);
  return slot.get();
}

MapPoint* Map::restore_point(std::uint64_t id, const Eigen::Vector3d& position, KeyFrame* reference,
                             std::uint64_t first_keyframe_id, std::uint64_t first_frame_id) {
  std::unique_ptr<MapPoint>& slot = free_slot(points_, id, "map point");
  slot = std::make_unique<MapPoint>(id, position, reference, first_keyframe_id, first_frame_id);
  return slot.get();
}

void Map::add_observation(MapPoint* point, KeyFrame* keyframe, int feature) {
  point->observations[keyframe] = feature;
  keyframe->set_point(static_cast<std::size_t>(feature), point);
}

void Map::erase_observation(MapPoint* point, KeyFrame* keyframe) {
  const auto it = point->observations.find(keyframe);
  if (it == point->observations.end()) return;
  if (keyframe->points[static_cast<std::size_t>(it->second)] == point) {
    keyframe->set_point(static_cast<std::size_t>(it->second), nullptr);
  }
  point->observations.erase(it);
  if (point->reference == keyframe) {
    point->reference = point->observations.empty() ? nullptr : point->observations.begin()->first;
  }
  if (point->num_observations() <= 2) set_bad(point);
}

void Map::set_bad(MapPoint* point) {
  point->bad = true;
  for (const auto& [keyframe, feature] : point->observations) {
    if (keyframe->points[static_cast<std::size_t>(feature)] == point) {
      keyframe->set_point(static_cast<std::size_t>(feature), nullptr);
    }
  }
  point->observations.clear();
}

void Map::replace(MapPoint* point, MapPoint* into) {
  if (point == into || point == nullptr || into == nullptr) return;
  for (const auto& [keyframe, feature] : point->observations) {
    if (into->observations.find(keyframe) == into->observations.end()) {
      add_observation(into, keyframe, feature);
    } else if (keyframe->points[static_cast<std::size_t>(feature)] == point) {
      keyframe->set_point(static_cast<std::size_t>(feature), nullptr);
    }
  }
  into->found += point->found;
  into->visible += point->visible;
  point->observations.clear();
  point->bad = true;
  point->replaced_by = into;
  into->update_descriptor();
}

void Map::set_bad(KeyFrame* keyframe) {
  if (keyframe->id == 0 || keyframe->bad || !keyframe->loop_edges.empty()) return;
  if (keyframe->parent != nullptr) keyframe->T_c_parent = keyframe->T_cw * keyframe->parent->T_cw.inverse();
  for (const auto& [other, weight] : keyframe->connections) other->erase_connection(keyframe);
  for (MapPoint* point : keyframe->points) {
    if (point != nullptr) erase_observation(point, keyframe);
  }
  // Re-parent the children: repeatedly give the child with the strongest edge to an already-placed
  // keyframe (the parent first) that keyframe as parent, as ORB-SLAM2 does.
  std::set<KeyFrame*, ById> candidates;
  if (keyframe->parent != nullptr) candidates.insert(keyframe->parent);
  IdMap<KeyFrame, int> orphans = keyframe->children;
  while (!orphans.empty()) {
    KeyFrame* best_child = nullptr;
    KeyFrame* best_parent = nullptr;
    int best_weight = -1;
    for (const auto& [child, unused] : orphans) {
      if (child->bad) continue;
      for (const auto& [neighbour, weight] : child->connections) {
        if (candidates.count(neighbour) != 0 && weight > best_weight) {
          best_child = child;
          best_parent = neighbour;
          best_weight = weight;
        }
      }
    }
    if (best_child == nullptr) break;
    best_child->parent = best_parent;
    best_parent->children[best_child] = 0;
    candidates.insert(best_child);
    orphans.erase(best_child);
  }
  for (const auto& [child, unused] : orphans) {  // no covisible link to the tree: hang on the parent
    child->parent = keyframe->parent;
    if (keyframe->parent != nullptr) keyframe->parent->children[child] = 0;
  }
  if (keyframe->parent != nullptr) keyframe->parent->children.erase(keyframe);
  keyframe->children.clear();
  keyframe->connections.clear();
  keyframe->bad = true;
}

std::vector<KeyFrame*> Map::keyframes() const {
  std::vector<KeyFrame*> out;
  for (const auto& keyframe : keyframes_) {
    if (keyframe != nullptr && !keyframe->bad) out.push_back(keyframe.get());
  }
  return out;
}

std::vector<MapPoint*> Map::points() const {
  std::vector<MapPoint*> out;
  for (const auto& point : points_) {
    if (point != nullptr && !point->bad) out.push_back(point.get());
  }
  return out;
}

std::size_t Map::num_keyframes() const { return keyframes().size(); }
std::size_t Map::num_points() const { return points().size(); }

KeyFrame* Map::keyframe_by_id(std::uint64_t id) const {
  return id < keyframes_.size() ? keyframes_[id].get() : nullptr;
}

}  // namespace porta::slam
