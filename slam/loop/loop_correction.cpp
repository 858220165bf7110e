// Loop closing step 3: the correction (after ORB-SLAM2's LoopClosing::CorrectLoop and
// Optimizer::OptimizeEssentialGraph, SE(3) for stereo); see loop_steps.hpp. The caller holds
// Map::mutex throughout, so nobody sees the map half-corrected.
#include <algorithm>
#include <map>
#include <set>
#include <utility>

#include "../mapping/mapping_steps.hpp"
#include "loop_steps.hpp"
#include "porta/slam/optim/pose_graph.hpp"

namespace porta::slam::loop {
namespace {

constexpr double kFuseWindow = 4.0;  // ORB-SLAM2's SearchAndFuse(th = 4)

using PoseMap = std::map<KeyFrame*, SE3, ById>;

/// The essential graph over the map's keyframes: spanning tree, loop edges, strong covisibility
/// (measured with the poses before the correction, `before`) and the loop's new links (measured
/// with the corrected poses, which they connect).
struct EssentialGraph {
  std::vector<KeyFrame*> keyframes;
  std::map<KeyFrame*, std::size_t, ById> index;
  std::vector<optim::PoseGraphVertex> vertices;
  std::vector<optim::PoseGraphEdge> edges;
  std::set<std::pair<std::size_t, std::size_t>> linked;

  void add_edge(KeyFrame* a, KeyFrame* b, const SE3& T_aw, const SE3& T_bw) {
    const auto ia = index.find(a), ib = index.find(b);
    if (ia == index.end() || ib == index.end() || a == b) return;
    const auto key = std::minmax(ia->second, ib->second);
    if (!linked.insert(key).second) return;
    edges.push_back({ia->second, ib->second, T_aw * T_bw.inverse(), 1.0});
  }
};

/// Keyframes local mapping has not linked yet (no parent) are left out of the graph; they follow
/// the closest older keyframe in it afterwards.
bool in_graph(const KeyFrame* k) { return k->id == 0 || k->parent != nullptr; }

EssentialGraph build_essential_graph(const Map& map, KeyFrame* fixed, const PoseMap& before,
                                     const std::map<KeyFrame*, std::set<KeyFrame*, ById>, ById>& new_links) {
  EssentialGraph g;
  for (KeyFrame* k : map.keyframes()) {
    if (!in_graph(k)) continue;
    g.index[k] = g.keyframes.size();
    g.keyframes.push_back(k);
    g.vertices.push_back({k->T_cw, k == fixed});
  }
  const auto old_pose = [&](KeyFrame* k) {
    const auto it = before.find(k);
    return it != before.end() ? it->second : k->T_cw;
  };
  for (const auto& [k, links] : new_links) {
    for (KeyFrame* n : links) g.add_edge(k, n, k->T_cw, n->T_cw);
  }
  for (KeyFrame* k : g.keyframes) {
    if (k->parent != nullptr) g.add_edge(k, k->parent, old_pose(k), old_pose(k->parent));
    for (const auto& [l, unused] : k->loop_edges) {
      if (l->id < k->id) g.add_edge(k, l, old_pose(k), old_pose(l));
    }
    for (KeyFrame* n : k->covisibles_with_weight(kEssentialCovisibility)) {
      if (n->id < k->id) g.add_edge(k, n, old_pose(k), old_pose(n));
    }
  }
  return g;
}

}  // namespace

double correct_loop(Map& map, KeyFrame* query, KeyFrame* candidate, const LoopMatch& match,
                    const SlamSettings& settings, const ScalePyramid& pyramid) {
  const StereoCamera& camera = settings.camera;
  PoseMap before;
  for (KeyFrame* k : map.keyframes()) before[k] = k->T_cw;
  const Eigen::Vector3d query_center_before = query->center();

  // 1. The query and its neighbours move by the correction; their points with them (each by the
  //    first group keyframe that sees it).
  std::vector<KeyFrame*> group{query};
  for (KeyFrame* k : query->covisibles_with_weight(0)) group.push_back(k);
  const SE3 T_wq = query->T_cw.inverse();
  std::map<MapPoint*, KeyFrame*, ById> corrected_by;
  for (KeyFrame* k : group) {
    const SE3 T_kw = k->T_cw * T_wq * match.T_qw;
    const SE3 move = T_kw.inverse() * k->T_cw;  // old world -> corrected world, for k's points
    for (MapPoint* p : k->points) {
      if (p == nullptr || p->bad || corrected_by.count(p) != 0) continue;
      p->position = move * p->position;
      corrected_by[p] = k;
    }
    k->T_cw = T_kw;
  }
  for (const auto& [p, k] : corrected_by) p->update_normal_and_depth(pyramid);

  // 2. The loop's points replace the query's duplicates (the older point survives).
  for (std::size_t i = 0; i < match.matched.size(); ++i) {
    MapPoint* loop_point = match.matched[i];
    if (loop_point == nullptr || loop_point->bad) continue;
    MapPoint* existing = query->points[i];
    if (existing != nullptr && !existing->bad) {
      if (existing != loop_point) Map::replace(existing, loop_point);
    } else if (loop_point->observations.count(query) == 0) {
      Map::add_observation(loop_point, query, static_cast<int>(i));
      loop_point->update_descriptor();
    }
  }
  // 3. ... and the group's (ORB-SLAM2's SearchAndFuse with the corrected poses).
  for (KeyFrame* k : group) {
    if (!k->bad) mapping::fuse_points_into(k, match.loop_points, camera, pyramid, kFuseWindow);
  }

  // 4. The links the loop made: new covisible neighbours outside the group.
  std::set<KeyFrame*, ById> group_set(group.begin(), group.end());
  std::map<KeyFrame*, std::set<KeyFrame*, ById>, ById> new_links;
  for (KeyFrame* k : group) {
    if (k->bad) continue;
    std::set<KeyFrame*, ById> previous;
    for (const auto& [n, weight] : k->connections) previous.insert(n);
    k->update_connections();
    for (const auto& [n, weight] : k->connections) {
      if (previous.count(n) == 0 && group_set.count(n) == 0) new_links[k].insert(n);
    }
  }
  new_links[query].insert(candidate);  // the loop itself, even if fusion left it weakly connected

  // 5. The essential graph, the loop keyframe held.
  EssentialGraph graph = build_essential_graph(map, candidate, before, new_links);
  optim::PoseGraphOptions options;
  options.iterations = 20;
  options.num_threads = 1;  // deterministic
  const optim::PoseGraphResult result = optim::optimize_pose_graph(graph.vertices, graph.edges, options);

  // 6. Every keyframe takes its new pose: the graph's, or (not in the graph) the closest older
  //    graph keyframe's motion; every point follows the keyframe that corrected it, else its
  //    reference.
  PoseMap pre, post;
  for (std::size_t v = 0; v < graph.keyframes.size(); ++v) {
    pre[graph.keyframes[v]] = graph.vertices[v].T_cw;
    post[graph.keyframes[v]] = result.T_cw[v];
  }
  KeyFrame* last_in_graph = nullptr;
  for (KeyFrame* k : map.keyframes()) {
    if (post.count(k) != 0) {
      last_in_graph = k;
      continue;
    }
    pre[k] = k->T_cw;
    post[k] = last_in_graph == nullptr ? k->T_cw
                                       : k->T_cw * pre[last_in_graph].inverse() * post[last_in_graph];
  }
  for (MapPoint* p : map.points()) {
    const auto c = corrected_by.find(p);
    KeyFrame* r = c != corrected_by.end() ? c->second : p->reference;
    if (r == nullptr || r->bad || post.count(r) == 0) {
      r = nullptr;
      for (const auto& [observer, feature] : p->observations) {
        if (!observer->bad && post.count(observer) != 0) {
          r = observer;
          break;
        }
      }
    }
    if (r == nullptr) continue;
    p->position = post[r].inverse() * (pre[r] * p->position);
  }
  for (const auto& [k, T_cw] : post) k->T_cw = T_cw;
  for (MapPoint* p : map.points()) p->update_normal_and_depth(pyramid);

  // 7. The loop edge keeps both keyframes in the map and in every later essential graph.
  query->loop_edges[candidate] = 0;
  candidate->loop_edges[query] = 0;
  ++map.correction_generation;
  return (query->center() - query_center_before).norm();
}

}  // namespace porta::slam::loop
