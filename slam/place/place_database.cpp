// PlaceDatabase: the keyframe database over one DescriptorTree (place_recognition.hpp).
#include <algorithm>
#include <unordered_map>

#include "place_bytes.hpp"
#include "porta/slam/map.hpp"
#include "porta/slam/place_recognition.hpp"

namespace porta::slam {

namespace {
constexpr std::uint32_t kFormatVersion = 1;
}

void PlaceRecognitionOptions::validate() const {
  if (max_leaf_size < 2 || max_leaf_size > 4096) {
    throw std::invalid_argument("PlaceRecognitionOptions::max_leaf_size must be in [2, 4096], got " +
                                std::to_string(max_leaf_size));
  }
  if (match_distance < 0 || match_distance > 256) {
    throw std::invalid_argument("PlaceRecognitionOptions::match_distance must be in [0, 256], got " +
                                std::to_string(match_distance));
  }
}

PlaceDatabase::PlaceDatabase(const PlaceRecognitionOptions& options)
    : options_(options), tree_((options.validate(), options.max_leaf_size)) {}

bool PlaceDatabase::contains(std::uint64_t keyframe) const {
  const auto it = std::lower_bound(descriptors_per_keyframe_.begin(), descriptors_per_keyframe_.end(),
                                   std::pair<std::uint64_t, std::uint32_t>{keyframe, 0});
  return it != descriptors_per_keyframe_.end() && it->first == keyframe;
}

void PlaceDatabase::add(std::uint64_t keyframe, std::span<const Descriptor> descriptors) {
  if (contains(keyframe)) {
    throw std::invalid_argument("PlaceDatabase::add: keyframe " + std::to_string(keyframe) + " is already stored");
  }
  tree_.insert(keyframe, descriptors);
  const auto it = std::lower_bound(descriptors_per_keyframe_.begin(), descriptors_per_keyframe_.end(),
                                   std::pair<std::uint64_t, std::uint32_t>{keyframe, 0});
  descriptors_per_keyframe_.insert(it, {keyframe, static_cast<std::uint32_t>(descriptors.size())});
}

void PlaceDatabase::erase(std::uint64_t keyframe, std::span<const Descriptor> descriptors) {
  const auto it = std::lower_bound(descriptors_per_keyframe_.begin(), descriptors_per_keyframe_.end(),
                                   std::pair<std::uint64_t, std::uint32_t>{keyframe, 0});
  if (it == descriptors_per_keyframe_.end() || it->first != keyframe) return;
  tree_.erase(keyframe, descriptors);
  descriptors_per_keyframe_.erase(it);
}

std::vector<PlaceScore> PlaceDatabase::query(std::span<const Descriptor> descriptors,
                                             std::span<const std::uint64_t> exclude) const {
  // Per query descriptor, every keyframe with an entry within match_distance in its leaf votes
  // once. The hash map only counts; the result is sorted, so its order does not leak out.
  std::unordered_map<std::uint64_t, int> votes;
  std::vector<std::uint64_t> voters;
  for (const Descriptor& q : descriptors) {
    voters.clear();
    for (const TreeEntry& e : tree_.leaf_of(q)) {
      if (hamming_distance(q, e.descriptor) <= options_.match_distance) voters.push_back(e.keyframe);
    }
    std::sort(voters.begin(), voters.end());
    voters.erase(std::unique(voters.begin(), voters.end()), voters.end());
    for (const std::uint64_t k : voters) ++votes[k];
  }
  std::vector<PlaceScore> scores;
  scores.reserve(votes.size());
  const double n = std::max<std::size_t>(1, descriptors.size());
  for (const auto& [keyframe, matched] : votes) {
    if (std::binary_search(exclude.begin(), exclude.end(), keyframe)) continue;
    scores.push_back({keyframe, matched, matched / n});
  }
  std::sort(scores.begin(), scores.end(), [](const PlaceScore& a, const PlaceScore& b) {
    return a.matched != b.matched ? a.matched > b.matched : a.keyframe < b.keyframe;
  });
  return scores;
}

std::vector<std::uint8_t> PlaceDatabase::serialize() const {
  std::vector<std::uint8_t> out;
  place_bytes::put<std::uint32_t>(out, kFormatVersion);
  place_bytes::put<std::uint64_t>(out, options_.max_leaf_size);
  place_bytes::put<std::int32_t>(out, options_.match_distance);
  place_bytes::put<std::uint64_t>(out, descriptors_per_keyframe_.size());
  for (const auto& [keyframe, count] : descriptors_per_keyframe_) {
    place_bytes::put<std::uint64_t>(out, keyframe);
    place_bytes::put<std::uint32_t>(out, count);
  }
  tree_.serialize(out);
  return out;
}

PlaceDatabase PlaceDatabase::deserialize(std::span<const std::uint8_t> bytes) {
  place_bytes::Reader in{bytes, 0, "header"};
  const auto version = in.get<std::uint32_t>();
  if (version != kFormatVersion) {
    in.fail("has format version " + std::to_string(version) + ", this program reads " +
            std::to_string(kFormatVersion));
  }
  PlaceRecognitionOptions options;
  options.max_leaf_size = static_cast<std::size_t>(in.get<std::uint64_t>());
  options.match_distance = in.get<std::int32_t>();
  try {
    options.validate();
  } catch (const std::invalid_argument& e) {
    in.fail(std::string("has bad options: ") + e.what());
  }
  PlaceDatabase database(options);
  in.what = "keyframe list";
  const auto keyframes = in.get_count(12);
  database.descriptors_per_keyframe_.reserve(static_cast<std::size_t>(keyframes));
  std::uint64_t total = 0;
  for (std::uint64_t k = 0; k < keyframes; ++k) {
    const auto keyframe = in.get<std::uint64_t>();
    const auto count = in.get<std::uint32_t>();
    if (!database.descriptors_per_keyframe_.empty() && keyframe <= database.descriptors_per_keyframe_.back().first) {
      in.fail("is not in increasing keyframe order at keyframe " + std::to_string(keyframe));
    }
    database.descriptors_per_keyframe_.emplace_back(keyframe, count);
    total += count;
  }
  std::size_t offset = in.offset;
  database.tree_ = DescriptorTree::deserialize(bytes, offset);
  if (database.tree_.size() != total || database.tree_.max_leaf_size() != options.max_leaf_size) {
    throw PlaceDatabaseError("place database: the tree holds " + std::to_string(database.tree_.size()) +
                             " descriptors, the keyframe list " + std::to_string(total));
  }
  if (offset != bytes.size()) {
    throw PlaceDatabaseError("place database: " + std::to_string(bytes.size() - offset) +
                             " bytes after the end of the tree");
  }
  return database;
}

}  // namespace porta::slam
