// DescriptorTree: the HBST-style binary search tree over descriptors (place_recognition.hpp).
#include <algorithm>
#include <cstring>
#include <limits>

#include "place_bytes.hpp"
#include "porta/slam/place_recognition.hpp"

namespace porta::slam {
namespace {

int bit_of(const Descriptor& d, int bit) { return (d.bytes[static_cast<std::size_t>(bit >> 3)] >> (bit & 7)) & 1; }

}  // namespace

DescriptorTree::DescriptorTree(std::size_t max_leaf_size) : max_leaf_size_(max_leaf_size) {
  if (max_leaf_size_ < 2) throw std::invalid_argument("DescriptorTree: max_leaf_size must be >= 2");
  nodes_.emplace_back();  // the root, a leaf
}

std::uint32_t DescriptorTree::leaf_index(const Descriptor& d) const {
  std::uint32_t node = 0;
  while (nodes_[node].bit >= 0) node = nodes_[node].child[bit_of(d, nodes_[node].bit)];
  return node;
}

const std::vector<TreeEntry>& DescriptorTree::leaf_of(const Descriptor& query) const {
  return nodes_[leaf_index(query)].entries;
}

void DescriptorTree::split(std::uint32_t leaf) {
  // Count the ones of every bit over the leaf's entries; split on the most even bit.
  std::vector<TreeEntry>& entries = nodes_[leaf].entries;
  int ones[256] = {};
  for (const TreeEntry& e : entries) {
    for (int byte = 0; byte < 32; ++byte) {
      const std::uint8_t v = e.descriptor.bytes[static_cast<std::size_t>(byte)];
      if (v == 0) continue;
      for (int b = 0; b < 8; ++b) ones[byte * 8 + b] += (v >> b) & 1;
    }
  }
  const long half2 = static_cast<long>(entries.size());  // compare 2*ones with the size: no rounding
  int best_bit = -1;
  long best_gap = std::numeric_limits<long>::max();
  for (int bit = 0; bit < 256; ++bit) {
    if (ones[bit] == 0 || ones[bit] == static_cast<int>(entries.size())) continue;  // does not split
    const long gap = std::abs(2L * ones[bit] - half2);
    if (gap < best_gap) {
      best_gap = gap;
      best_bit = bit;
    }
  }
  if (best_bit < 0) return;  // all entries identical: nothing can separate them
  Node zero, one;
  for (TreeEntry& e : entries) (bit_of(e.descriptor, best_bit) != 0 ? one : zero).entries.push_back(e);
  const auto first_child = static_cast<std::uint32_t>(nodes_.size());
  nodes_[leaf].entries.clear();
  nodes_[leaf].entries.shrink_to_fit();
  nodes_[leaf].bit = best_bit;
  nodes_[leaf].child[0] = first_child;
  nodes_[leaf].child[1] = first_child + 1;
  nodes_.push_back(std::move(zero));  // may reallocate: `entries` is not used after this
  nodes_.push_back(std::move(one));
}

void DescriptorTree::insert(std::uint64_t keyframe, std::span<const Descriptor> descriptors) {
  for (std::size_t i = 0; i < descriptors.size(); ++i) {
    const std::uint32_t leaf = leaf_index(descriptors[i]);
    nodes_[leaf].entries.push_back({descriptors[i], keyframe, static_cast<std::uint32_t>(i)});
    ++size_;
    if (nodes_[leaf].entries.size() > max_leaf_size_) split(leaf);
  }
}

void DescriptorTree::erase(std::uint64_t keyframe, std::span<const Descriptor> descriptors) {
  for (std::size_t i = 0; i < descriptors.size(); ++i) {
    std::vector<TreeEntry>& entries = nodes_[leaf_index(descriptors[i])].entries;
    const auto it = std::find_if(entries.begin(), entries.end(), [&](const TreeEntry& e) {
      return e.keyframe == keyframe && e.feature == static_cast<std::uint32_t>(i);
    });
    if (it == entries.end()) continue;
    entries.erase(it);  // keeps the others in insertion order
    --size_;
  }
}

int DescriptorTree::depth() const {
  int deepest = 0;
  std::vector<std::pair<std::uint32_t, int>> stack{{0u, 0}};
  while (!stack.empty()) {
    const auto [node, d] = stack.back();
    stack.pop_back();
    deepest = std::max(deepest, d);
    if (nodes_[node].bit >= 0) {
      stack.emplace_back(nodes_[node].child[0], d + 1);
      stack.emplace_back(nodes_[node].child[1], d + 1);
    }
  }
  return deepest;
}

void DescriptorTree::serialize(std::vector<std::uint8_t>& out) const {
  place_bytes::put<std::uint64_t>(out, max_leaf_size_);
  place_bytes::put<std::uint64_t>(out, nodes_.size());
  for (const Node& node : nodes_) {
    place_bytes::put<std::int32_t>(out, node.bit);
    if (node.bit >= 0) {
      place_bytes::put<std::uint32_t>(out, node.child[0]);
      place_bytes::put<std::uint32_t>(out, node.child[1]);
      continue;
    }
    place_bytes::put<std::uint64_t>(out, node.entries.size());
    for (const TreeEntry& e : node.entries) {
      place_bytes::put_bytes(out, e.descriptor.bytes.data(), e.descriptor.bytes.size());
      place_bytes::put<std::uint64_t>(out, e.keyframe);
      place_bytes::put<std::uint32_t>(out, e.feature);
    }
  }
}

DescriptorTree DescriptorTree::deserialize(std::span<const std::uint8_t> bytes, std::size_t& offset) {
  place_bytes::Reader in{bytes, offset, "descriptor tree"};
  const auto max_leaf = in.get<std::uint64_t>();
  if (max_leaf < 2 || max_leaf > (1u << 20)) in.fail("max_leaf_size " + std::to_string(max_leaf) + " is out of range");
  DescriptorTree tree(static_cast<std::size_t>(max_leaf));
  // Every node takes at least 4 bytes: a count larger than the rest cannot be right.
  const auto count = in.get_count(4);
  if (count == 0) in.fail("has no root node");
  tree.nodes_.assign(static_cast<std::size_t>(count), Node{});
  constexpr std::size_t kEntryBytes = 32 + 8 + 4;
  for (std::size_t n = 0; n < tree.nodes_.size(); ++n) {
    Node& node = tree.nodes_[n];
    node.bit = in.get<std::int32_t>();
    if (node.bit >= 256 || node.bit < -1) in.fail("node " + std::to_string(n) + " tests bit " + std::to_string(node.bit));
    if (node.bit >= 0) {
      for (std::uint32_t& child : node.child) {
        child = in.get<std::uint32_t>();
        // Children come after their parent (split() appends them): no cycles.
        if (child <= n || child >= tree.nodes_.size()) {
          in.fail("node " + std::to_string(n) + " has child " + std::to_string(child) + " out of range");
        }
      }
      continue;
    }
    const auto entries = in.get_count(kEntryBytes);
    node.entries.resize(static_cast<std::size_t>(entries));
    for (TreeEntry& e : node.entries) {
      in.get_bytes(e.descriptor.bytes.data(), e.descriptor.bytes.size());
      e.keyframe = in.get<std::uint64_t>();
      e.feature = in.get<std::uint32_t>();
    }
    tree.size_ += node.entries.size();
  }
  offset = in.offset;
  return tree;
}

}  // namespace porta::slam
