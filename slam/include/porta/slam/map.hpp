// The SLAM map: map points, keyframes with their covisibility graph and spanning tree, and the Map
// that owns them (DESIGN.md §6).
//
// Ownership: the Map owns every KeyFrame and MapPoint (unique_ptr) for its whole life; everything
// else holds plain non-owning pointers. Culled objects are flagged bad, unlinked, and kept until the
// Map is destroyed, so a pointer held by another thread never dangles.
//
// Locking (one scheme, no per-object locks): Map::mutex guards every KeyFrame and MapPoint field
// and the Map's lists. Tracking and local mapping lock it for each read-modify step; long work
// (bundle adjustment) copies what it needs under the lock, computes without it, and writes back
// under it, skipping objects that turned bad meanwhile. Methods below expect the caller to hold
// the lock unless they say otherwise.
//
// Determinism: every container that is iterated is ordered by object id (never by pointer value),
// so the same input gives the same map and trajectory in the deterministic mode.
#pragma once

#include <atomic>
#include <bit>
#include <cstdint>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <vector>

#include "porta/keypoint.hpp"
#include "porta/slam/frame.hpp"
#include "porta/slam/id_map.hpp"
#include "porta/slam/map_mutex.hpp"

namespace porta::slam {

/// Orders pointers to map objects by their id.
struct ById {
  template <class T>
  bool operator()(const T* a, const T* b) const {
    return a->id < b->id;
  }
};

/// Hamming distance of two 256-bit descriptors (four 64-bit words; the byte order does not matter
/// for a count of differing bits). Inline: it is the inner loop of every descriptor search.
inline int hamming_distance(const Descriptor& a, const Descriptor& b) {
  std::uint64_t wa[4], wb[4];
  std::memcpy(wa, a.bytes.data(), sizeof(wa));
  std::memcpy(wb, b.bytes.data(), sizeof(wb));
  return std::popcount(wa[0] ^ wb[0]) + std::popcount(wa[1] ^ wb[1]) + std::popcount(wa[2] ^ wb[2]) +
         std::popcount(wa[3] ^ wb[3]);
}

/// Aligned to a cache line, with what tracking's local-map scan reads of every point first: the
/// position, its marks and `bad` in the first line, the normal, the distance range and the
/// descriptor (of the points in view) in the second.
class alignas(64) MapPoint {
 public:
  MapPoint(std::uint64_t id, const Eigen::Vector3d& position, KeyFrame* reference, std::uint64_t first_frame_id);
  /// For a point read back from a map file: `first_keyframe_id` as saved (its keyframe may be gone).
  MapPoint(std::uint64_t id, const Eigen::Vector3d& position, KeyFrame* reference,
           std::uint64_t first_keyframe_id, std::uint64_t first_frame_id);

  Eigen::Vector3d position;
  /// Tracking's marks, under Map::mutex and not saved: the last local-map build that listed the
  /// point and the last frame that matched it (membership tests without a hash set per frame).
  std::uint64_t tracking_local_mark = 0, tracking_frame_mark = 0;
  int visible = 1;   ///< frames whose view frustum contained it
  int found = 1;     ///< frames that matched it
  bool bad = false;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  ///< mean viewing direction (unit)
  double min_distance = 0.0, max_distance = 0.0;     ///< scale-invariance distance range
  Descriptor descriptor;                        ///< the observation with the least median distance to the others
  const std::uint64_t id;
  IdMap<KeyFrame, int> observations;            ///< keyframe -> feature index
  KeyFrame* reference = nullptr;
  const std::uint64_t first_keyframe_id;
  const std::uint64_t first_frame_id;
  MapPoint* replaced_by = nullptr;
  /// Local mapping's pass mark (mapping::new_pass_mark: bundle adjustment's collection, fusion's
  /// candidate list), under Map::mutex.
  std::uint64_t collect_mark = 0;

  int num_observations() const;  ///< stereo observations count 2, as in ORB-SLAM2
  double found_ratio() const { return static_cast<double>(found) / visible; }
  /// Recomputes `descriptor` from the observing keyframes' descriptors.
  void update_descriptor();
  /// Recomputes `normal` and the distance range from the observing keyframes' centres.
  void update_normal_and_depth(const ScalePyramid& pyramid);
  /// Pyramid level at which a point at `distance` should be seen (ORB-SLAM2's PredictScale).
  int predict_level(double distance, const ScalePyramid& pyramid) const;
};

class KeyFrame {
 public:
  KeyFrame(std::uint64_t id, const Frame& frame);

  const std::uint64_t id;
  const std::uint64_t frame_id;
  const double time_s;
  const std::shared_ptr<const FrameFeatures> features;
  const FeatureGrid grid;
  SE3 T_cw;
  /// Per feature, nullptr = none. Read freely; once the keyframe is in the map, write it only
  /// through set_point, which counts the edits that tracking's local-point list follows.
  std::vector<MapPoint*> points;
  bool bad = false;
  /// Writes to `points` through set_point so far (tracking::LocalPoints keeps what it listed of
  /// an unedited keyframe from one frame to the next).
  std::uint64_t points_edits = 0;

  // Covisibility graph: weight = number of map points seen by both keyframes.
  IdMap<KeyFrame, int> connections;
  KeyFrame* parent = nullptr;  ///< spanning tree: the keyframe it shares most points with (at creation)
  IdMap<KeyFrame, int> children;  ///< value unused (kept for ordered iteration)
  /// Keyframes this one closed a loop with (both ways; value unused). Loop keyframes are never
  /// culled: the essential graph needs the edge.
  IdMap<KeyFrame, int> loop_edges;
  /// Set when the keyframe is culled: its pose relative to its parent then (T_cw * T_parent_w^-1),
  /// so that frames that referred to it follow the parent through later corrections (ORB-SLAM2's Tcp).
  SE3 T_c_parent = SE3::Identity();
  /// Tracking's marks, under Map::mutex and not saved: the last frame whose points voted for this
  /// keyframe with their count, and the last local map that listed it.
  std::uint64_t tracking_vote_mark = 0, tracking_local_mark = 0;
  int tracking_votes = 0;
  /// Bundle adjustment's collection mark and this keyframe's index in that problem, under Map::mutex.
  std::uint64_t collect_mark = 0;
  std::size_t collect_index = 0;

  Eigen::Vector3d center() const { return T_cw.inverse().translation(); }
  /// points[feature] = point, counted in points_edits.
  void set_point(std::size_t feature, MapPoint* point) {
    points[feature] = point;
    ++points_edits;
  }
  /// Map points with at least `min_observations` observations (0: all good points).
  int tracked_points(int min_observations) const;
  /// Recomputes `connections` from the map points and updates the other side of each edge.
  /// Edges need at least `min_weight` shared points (ORB-SLAM2: 15; the best one is always kept).
  /// Sets the parent the first time a connection appears.
  void update_connections(int min_weight = 15);
  /// Up to `n` neighbours by decreasing weight (ties: smaller id first).
  std::vector<KeyFrame*> best_covisibles(std::size_t n) const;
  /// Neighbours with weight >= `min_weight`, by decreasing weight.
  std::vector<KeyFrame*> covisibles_with_weight(int min_weight) const;
  void erase_connection(KeyFrame* other);
};

class Map {
 public:
  /// Guards all map data (see the file comment).
  mutable MapMutex mutex;
  /// Counts corrections that move the whole map (loop closing, global bundle adjustment write-back),
  /// under `mutex`. Work computed on a copy (local bundle adjustment) is discarded when this changed
  /// while it ran: writing it back would undo the correction.
  std::uint64_t correction_generation = 0;

  /// Takes `mutex` for a thread whose latency counts (tracking): while it waits, long work under
  /// the lock hands the lock over at its next yield_to_waiters(). Does not need the lock.
  std::unique_lock<MapMutex> lock_first();
  /// Called with `lock` (on `mutex`) held, between units of long work (local mapping's fusion):
  /// when a lock_first() caller waits, releases the lock until that caller has taken it, then
  /// takes it back, which waits until the caller is done. Returns whether it released the lock:
  /// then anything read before may have changed. A no-op when nobody waits (deterministic mode).
  bool yield_to_waiters(std::unique_lock<MapMutex>& lock);

  KeyFrame* add_keyframe(const Frame& frame);
  MapPoint* add_point(const Eigen::Vector3d& position, KeyFrame* reference, std::uint64_t frame_id);

  /// Restoring a saved map (map_file.hpp): the object is placed at index `id`, so that the ids saved
  /// in the file stay valid. Ids that are not restored stay empty slots, which every list below
  /// skips; add_keyframe / add_point then continue after the largest id. Throws
  /// std::invalid_argument when `id` is taken. The caller bounds `id` (one pointer per slot).
  KeyFrame* restore_keyframe(std::uint64_t id, const Frame& frame);
  MapPoint* restore_point(std::uint64_t id, const Eigen::Vector3d& position, KeyFrame* reference,
                          std::uint64_t first_keyframe_id, std::uint64_t first_frame_id);
  /// True when nothing was ever added or restored (culled objects count: their ids are taken).
  bool empty() const { return keyframes_.empty() && points_.empty(); }

  /// Links point and keyframe feature both ways.
  static void add_observation(MapPoint* point, KeyFrame* keyframe, int feature);
  /// Unlinks both ways; a point left with fewer than 3 observations (stereo counted twice) goes bad,
  /// as in ORB-SLAM2.
  static void erase_observation(MapPoint* point, KeyFrame* keyframe);
  /// Flags a point bad and unlinks it from every keyframe.
  static void set_bad(MapPoint* point);
  /// Merges `point` into `into` (duplicate fusion): observations move over, `point` goes bad.
  static void replace(MapPoint* point, MapPoint* into);
  /// Culls a keyframe: unlinks its points and covisibility edges and re-parents its children
  /// (each to the connected keyframe it shares most points with). Keyframe 0 and keyframes with
  /// loop edges are never culled.
  static void set_bad(KeyFrame* keyframe);

  /// Good keyframes / points in id order.
  std::vector<KeyFrame*> keyframes() const;
  std::vector<MapPoint*> points() const;
  std::size_t num_keyframes() const;
  std::size_t num_points() const;
  KeyFrame* keyframe_by_id(std::uint64_t id) const;

 private:
  std::atomic<int> first_waiters_{0};  ///< lock_first() callers waiting for `mutex`
  std::vector<std::unique_ptr<KeyFrame>> keyframes_;  // index = id; null: an id not restored
  std::vector<std::unique_ptr<MapPoint>> points_;     // index = id; null: an id not restored
};

}  // namespace porta::slam
