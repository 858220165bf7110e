// Place recognition without a vocabulary (DESIGN.md §6): a binary search tree over the keyframes'
// ORB descriptors, in the manner of HBST (Schlegel and Grisetti, "HBST: A Hamming Distance
// Embedding Binary Search Tree for Feature-Based Visual Place Recognition", RA-L 2018), and the
// keyframe database built on it. Nothing is trained or downloaded: the tree grows from the
// descriptors of the keyframes it is given, so it fits any camera and starts empty in no time.
//
// The tree: an inner node tests one descriptor bit (bit j = byte j/8, bit j%8, LSB first) and sends
// a descriptor to child 0 or 1; a leaf holds up to `max_leaf_size` entries (descriptor, keyframe,
// feature). A leaf that grows past the limit splits on the bit whose count of ones over its entries
// is closest to half (ties: the lower bit), so the tree stays balanced whatever the descriptors'
// bit statistics. A query descends the same way, by its own bits, and compares itself only with
// the entries of the leaf it reaches: a descriptor near a stored one very likely (not always:
// HBST's trade) agrees with it on the few bits tested on the way. Everything is deterministic:
// the same insertions in the same order give the same tree, and the same query the same answer.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "porta/keypoint.hpp"

namespace porta::slam {

/// A place-recognition database that cannot be read (a corrupt or truncated map file section).
class PlaceDatabaseError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct PlaceRecognitionOptions {
  /// A leaf splits when it holds more entries than this (HBST uses 50-100).
  std::size_t max_leaf_size = 64;
  /// A stored descriptor matches a query within this Hamming distance. Tighter than ORB-SLAM2's
  /// matching bound (TH_LOW = 50): a vote needs no second-best test, and on the Oxford images
  /// chance votes at 45 bits outnumbered a zoomed view's true ones (docs/BENCHMARKS.md).
  int match_distance = 32;
  /// Throws std::invalid_argument naming the field.
  void validate() const;
};

/// One stored descriptor: feature `feature` of keyframe (or image) `keyframe`.
struct TreeEntry {
  Descriptor descriptor;
  std::uint64_t keyframe = 0;
  std::uint32_t feature = 0;
};

class DescriptorTree {
 public:
  explicit DescriptorTree(std::size_t max_leaf_size = 64);

  /// Stores descriptors[i] as feature i of `keyframe`.
  void insert(std::uint64_t keyframe, std::span<const Descriptor> descriptors);
  /// Removes what insert(keyframe, descriptors) stored (the same descriptors). Leaves stay split.
  void erase(std::uint64_t keyframe, std::span<const Descriptor> descriptors);
  /// The entries of the leaf `query` reaches, in insertion order (the query is not compared).
  const std::vector<TreeEntry>& leaf_of(const Descriptor& query) const;

  std::size_t size() const { return size_; }
  std::size_t nodes() const { return nodes_.size(); }
  std::size_t max_leaf_size() const { return max_leaf_size_; }
  /// Longest root-to-leaf path.
  int depth() const;

  /// Appends the tree (structure and entries) to `out`; read back by deserialize().
  void serialize(std::vector<std::uint8_t>& out) const;
  /// Reads what serialize() wrote from `bytes` at `offset` (advanced past it). Throws
  /// PlaceDatabaseError naming what is wrong (truncated, a child index out of range, ...).
  static DescriptorTree deserialize(std::span<const std::uint8_t> bytes, std::size_t& offset);

 private:
  struct Node {
    int bit = -1;                     // -1: a leaf
    std::uint32_t child[2] = {0, 0};  // node indices, when not a leaf
    std::vector<TreeEntry> entries;   // a leaf's entries
  };
  std::uint32_t leaf_index(const Descriptor& d) const;
  void split(std::uint32_t leaf);

  std::size_t max_leaf_size_;
  std::vector<Node> nodes_;
  std::size_t size_ = 0;
};

/// A keyframe's similarity to a query: how many query descriptors found a match in it.
struct PlaceScore {
  std::uint64_t keyframe = 0;
  int matched = 0;     ///< query descriptors with at least one of its descriptors within match_distance
  double score = 0.0;  ///< matched / number of query descriptors, in [0, 1]
};

/// The keyframe database: keyframes' descriptors in one DescriptorTree, queried by a keyframe or a
/// frame. Not thread-safe by itself: its owner (loop closing) serialises access.
class PlaceDatabase {
 public:
  explicit PlaceDatabase(const PlaceRecognitionOptions& options = {});

  void add(std::uint64_t keyframe, std::span<const Descriptor> descriptors);
  void erase(std::uint64_t keyframe, std::span<const Descriptor> descriptors);
  bool contains(std::uint64_t keyframe) const;
  std::size_t keyframes() const { return descriptors_per_keyframe_.size(); }
  std::size_t descriptors() const { return tree_.size(); }
  const DescriptorTree& tree() const { return tree_; }
  const PlaceRecognitionOptions& options() const { return options_; }

  /// Every stored keyframe sharing at least one match with the query, by decreasing `matched`
  /// (ties: smaller keyframe id first). `exclude` (sorted ascending) are left out.
  std::vector<PlaceScore> query(std::span<const Descriptor> descriptors,
                                std::span<const std::uint64_t> exclude = {}) const;

  /// The database as bytes (options, keyframe list, tree), for the map file.
  std::vector<std::uint8_t> serialize() const;
  /// Throws PlaceDatabaseError naming what is wrong.
  static PlaceDatabase deserialize(std::span<const std::uint8_t> bytes);

 private:
  PlaceRecognitionOptions options_;
  DescriptorTree tree_;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> descriptors_per_keyframe_;  // sorted by keyframe
};

}  // namespace porta::slam
