// Loop closing step 1: candidates from the place-recognition scores and the consistency test
// (after ORB-SLAM2's KeyFrameDatabase::DetectLoopCandidates / DetectRelocalizationCandidates and
// LoopClosing::DetectLoop); see loop_steps.hpp.
#include <algorithm>
#include <map>
#include <set>

#include "loop_steps.hpp"

namespace porta::slam::loop {
namespace {

constexpr std::size_t kGroupNeighbours = 10;
constexpr double kCommonMatchesRatio = 0.8;  // of the best candidate's matched descriptors
constexpr double kGroupScoreRatio = 0.75;    // of the best group's accumulated score

struct Scored {
  KeyFrame* keyframe = nullptr;
  int matched = 0;
  double score = 0.0;
};

/// Groups every candidate with its best covisibles that are candidates too, and returns the best
/// member of each group whose accumulated score is within kGroupScoreRatio of the best group's,
/// best group first (ties: the smaller id), each keyframe once.
std::vector<KeyFrame*> best_of_groups(const std::vector<Scored>& candidates) {
  std::map<KeyFrame*, const Scored*, ById> by_keyframe;
  for (const Scored& c : candidates) by_keyframe[c.keyframe] = &c;
  struct Group {
    double accumulated = 0.0;
    KeyFrame* best = nullptr;
  };
  std::vector<Group> groups;
  double best_accumulated = 0.0;
  for (const Scored& c : candidates) {
    Group group{c.score, c.keyframe};
    double best_score = c.score;
    for (KeyFrame* neighbour : c.keyframe->best_covisibles(kGroupNeighbours)) {
      const auto it = by_keyframe.find(neighbour);
      if (it == by_keyframe.end()) continue;
      group.accumulated += it->second->score;
      if (it->second->score > best_score) {
        best_score = it->second->score;
        group.best = neighbour;
      }
    }
    best_accumulated = std::max(best_accumulated, group.accumulated);
    groups.push_back(group);
  }
  std::stable_sort(groups.begin(), groups.end(), [](const Group& a, const Group& b) {
    return a.accumulated != b.accumulated ? a.accumulated > b.accumulated : a.best->id < b.best->id;
  });
  std::vector<KeyFrame*> out;
  std::set<std::uint64_t> taken;
  for (const Group& g : groups) {
    if (g.accumulated < kGroupScoreRatio * best_accumulated) break;
    if (taken.insert(g.best->id).second) out.push_back(g.best);
  }
  return out;
}

/// The scored keyframes that are good and pass `keep`, with at least 80 % of the best one's
/// matched descriptors (ORB-SLAM2's minCommonWords).
template <class Keep>
std::vector<Scored> common_candidates(const Map& map, const std::vector<PlaceScore>& scores, Keep&& keep) {
  std::vector<Scored> all;
  int most = 0;
  for (const PlaceScore& s : scores) {
    KeyFrame* keyframe = map.keyframe_by_id(s.keyframe);
    if (keyframe == nullptr || keyframe->bad || !keep(keyframe, s)) continue;
    all.push_back({keyframe, s.matched, s.score});
    most = std::max(most, s.matched);
  }
  std::vector<Scored> out;
  for (const Scored& c : all) {
    if (c.matched > kCommonMatchesRatio * most) out.push_back(c);
  }
  return out;
}

}  // namespace

std::vector<KeyFrame*> loop_candidates(const Map& map, KeyFrame* keyframe, const std::vector<PlaceScore>& scores) {
  // The least similar covisible neighbour sets the bar: a loop must look at least as much like the
  // keyframe as its own neighbourhood does. Neighbours the database did not score count as 0.
  std::map<std::uint64_t, double> score_of;
  for (const PlaceScore& s : scores) score_of[s.keyframe] = s.score;
  double min_score = 1.0;
  bool any_neighbour = false;
  for (const auto& [neighbour, weight] : keyframe->connections) {
    if (neighbour->bad) continue;
    any_neighbour = true;
    const auto it = score_of.find(neighbour->id);
    min_score = std::min(min_score, it == score_of.end() ? 0.0 : it->second);
  }
  if (!any_neighbour) return {};
  // A candidate whose neighbourhood already touches the keyframe's (a shared covisible keyframe) is
  // no new loop: the map is joined there already (by an earlier loop), and correcting the keyframe's
  // group would tear the keyframes both groups share away from the candidate's side.
  const auto already_joined = [&](KeyFrame* k) {
    for (const auto& [neighbour, weight] : k->connections) {
      if (neighbour == keyframe || keyframe->connections.count(neighbour) != 0) return true;
    }
    return false;
  };
  const std::vector<Scored> candidates = common_candidates(map, scores, [&](KeyFrame* k, const PlaceScore& s) {
    return k != keyframe && keyframe->connections.count(k) == 0 && s.score >= min_score && s.matched > 0 &&
           !already_joined(k);
  });
  if (candidates.empty()) return {};
  return best_of_groups(candidates);
}

std::vector<KeyFrame*> relocalisation_candidates(const Map& map, const std::vector<PlaceScore>& scores) {
  const std::vector<Scored> candidates =
      common_candidates(map, scores, [](KeyFrame*, const PlaceScore& s) { return s.matched > 0; });
  if (candidates.empty()) return {};
  return best_of_groups(candidates);
}

std::vector<KeyFrame*> consistent_candidates(const std::vector<KeyFrame*>& candidates,
                                             std::vector<ConsistentGroup>& groups) {
  std::vector<ConsistentGroup> current;
  std::vector<KeyFrame*> enough;
  std::vector<bool> previous_used(groups.size(), false);
  for (KeyFrame* candidate : candidates) {
    std::vector<std::uint64_t> members{candidate->id};
    for (const auto& [neighbour, weight] : candidate->connections) {
      if (!neighbour->bad) members.push_back(neighbour->id);
    }
    std::sort(members.begin(), members.end());
    bool consistent_with_any = false;
    bool counted = false;
    for (std::size_t g = 0; g < groups.size(); ++g) {
      std::vector<std::uint64_t> shared;
      std::set_intersection(members.begin(), members.end(), groups[g].keyframes.begin(), groups[g].keyframes.end(),
                            std::back_inserter(shared));
      if (shared.empty()) continue;
      consistent_with_any = true;
      const int consistency = groups[g].consistency + 1;
      if (!previous_used[g]) {  // each previous group continues at most one current group
        current.push_back({members, consistency});
        previous_used[g] = true;
      }
      if (consistency >= kConsistencyThreshold && !counted) {
        enough.push_back(candidate);
        counted = true;
      }
    }
    if (!consistent_with_any) current.push_back({members, 0});
  }
  groups = std::move(current);
  return enough;
}

}  // namespace porta::slam::loop
