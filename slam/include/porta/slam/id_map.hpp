// IdMap: a map from map objects (KeyFrame*, MapPoint*) to small values, kept as a vector sorted
// by the objects' ids: a map point's observations (2-20 keyframes), a keyframe's covisibility
// edges (tens), children and loop edges.
//
// It replaces std::map<T*, V, ById> there with the same interface and the same iteration order (by
// id), so every result is the same; what changes is the cost. Local mapping walks these maps
// millions of times per sequence (the bundle adjustment window, normals, descriptors, connections)
// and a tree walk is a chain of dependent pointer loads (std::_Rb_tree_increment was 3-4 % of the
// process's CPU as fast as possible on 2 cores); a vector is one contiguous read. Inserting or
// erasing moves the entries after the position, cheap at these sizes.
//
// Unlike std::map, inserting or erasing invalidates iterators and references into the same map.
// Callers do not change the map they are iterating (they change other objects' maps: the edge's
// other side, another point's observations).
#pragma once

#include <algorithm>
#include <cstddef>
#include <stdexcept>
#include <utility>
#include <vector>

namespace porta::slam {

template <class T, class V>
class IdMap {
 public:
  using key_type = T*;
  using mapped_type = V;
  using value_type = std::pair<T*, V>;
  using iterator = typename std::vector<value_type>::iterator;
  using const_iterator = typename std::vector<value_type>::const_iterator;

  iterator begin() { return entries_.begin(); }
  iterator end() { return entries_.end(); }
  const_iterator begin() const { return entries_.begin(); }
  const_iterator end() const { return entries_.end(); }
  std::size_t size() const { return entries_.size(); }
  bool empty() const { return entries_.empty(); }
  void clear() { entries_.clear(); }

  iterator find(const T* key) {
    const auto it = lower_bound(key);
    return it != entries_.end() && it->first == key ? it : entries_.end();
  }
  const_iterator find(const T* key) const {
    const auto it = lower_bound(key);
    return it != entries_.end() && it->first == key ? it : entries_.end();
  }
  std::size_t count(const T* key) const { return find(key) != end() ? 1 : 0; }
  bool contains(const T* key) const { return find(key) != end(); }

  V& at(const T* key) {
    const auto it = find(key);
    if (it == end()) throw std::out_of_range("IdMap::at: no entry for this object");
    return it->second;
  }
  const V& at(const T* key) const {
    const auto it = find(key);
    if (it == end()) throw std::out_of_range("IdMap::at: no entry for this object");
    return it->second;
  }

  /// The value of `key`, inserted as V{} when missing.
  V& operator[](T* key) { return emplace(key, V{}).first->second; }

  /// Inserts (key, value) unless key is present; the entry and whether it was inserted.
  std::pair<iterator, bool> emplace(T* key, V value) {
    const auto it = lower_bound(key);
    if (it != entries_.end() && it->first == key) return {it, false};
    return {entries_.insert(it, value_type{key, std::move(value)}), true};
  }

  std::size_t erase(const T* key) {
    const auto it = find(key);
    if (it == end()) return 0;
    entries_.erase(it);
    return 1;
  }
  iterator erase(const_iterator it) { return entries_.erase(it); }

  bool operator==(const IdMap& other) const { return entries_ == other.entries_; }

 private:
  iterator lower_bound(const T* key) {
    return std::lower_bound(entries_.begin(), entries_.end(), key,
                            [](const value_type& e, const T* k) { return e.first->id < k->id; });
  }
  const_iterator lower_bound(const T* key) const {
    return std::lower_bound(entries_.begin(), entries_.end(), key,
                            [](const value_type& e, const T* k) { return e.first->id < k->id; });
  }

  std::vector<value_type> entries_;
};

}  // namespace porta::slam
