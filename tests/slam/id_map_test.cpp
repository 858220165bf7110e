// IdMap (id_map.hpp): std::map's interface and order by id, in a vector.
#include <gtest/gtest.h>

#include <cstdint>
#include <stdexcept>
#include <vector>

#include "porta/slam/id_map.hpp"

namespace porta::slam {
namespace {

struct Object {
  std::uint64_t id;
};

std::vector<std::uint64_t> ids_of(const IdMap<Object, int>& map) {
  std::vector<std::uint64_t> ids;
  for (const auto& [object, value] : map) ids.push_back(object->id);
  return ids;
}

TEST(IdMap, IteratesByIdWhateverTheInsertionOrder) {
  // Addresses in the opposite order of the ids: the order must come from the ids.
  Object objects[5] = {{40}, {30}, {20}, {10}, {0}};
  IdMap<Object, int> map;
  for (const int k : {2, 0, 4, 1, 3}) map[&objects[k]] = static_cast<int>(objects[k].id) + 1;
  EXPECT_EQ(ids_of(map), (std::vector<std::uint64_t>{0, 10, 20, 30, 40}));
  for (const auto& [object, value] : map) EXPECT_EQ(value, static_cast<int>(object->id) + 1);
  EXPECT_EQ(map.size(), 5u);
}

TEST(IdMap, FindsCountsInsertsAndErasesLikeStdMap) {
  Object a{1}, b{2}, c{3}, absent{9};
  IdMap<Object, int> map;
  EXPECT_TRUE(map.empty());
  EXPECT_TRUE(map.emplace(&b, 20).second);
  EXPECT_FALSE(map.emplace(&b, 99).second) << "a present key keeps its value";
  EXPECT_EQ(map.at(&b), 20);
  EXPECT_EQ(map[&a], 0) << "operator[] inserts a value-initialised entry";
  map[&c] = 30;
  EXPECT_EQ(map.count(&c), 1u);
  EXPECT_EQ(map.count(&absent), 0u);
  EXPECT_TRUE(map.find(&absent) == map.end());
  EXPECT_THROW(static_cast<void>(map.at(&absent)), std::out_of_range);
  EXPECT_EQ(map.find(&c)->second, 30);

  EXPECT_EQ(map.erase(&absent), 0u);
  EXPECT_EQ(map.erase(&a), 1u);
  EXPECT_EQ(ids_of(map), (std::vector<std::uint64_t>{2, 3}));
  const auto next = map.erase(map.find(&b));
  ASSERT_TRUE(next != map.end());
  EXPECT_EQ(next->first, &c) << "erase(iterator) returns the entry after the erased one";

  IdMap<Object, int> copy = map;
  EXPECT_TRUE(copy == map);
  copy[&c] = 31;
  EXPECT_FALSE(copy == map);
  map.clear();
  EXPECT_TRUE(map.empty());
}

}  // namespace
}  // namespace porta::slam
