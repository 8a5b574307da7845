#include "landmarks/id_index.h"

#include <gtest/gtest.h>

#include <random>
#include <unordered_map>
#include <vector>

namespace twocam::landmarks {
namespace {

// Sequential ids created and freed in random order, as the tracker does, checked against
// std::unordered_map after every operation batch (growth and backward-shift deletion included).
TEST(IdIndex, AgreesWithAHashMapUnderRandomInsertsAndErases) {
  std::mt19937 rng(5);
  IdIndex index;
  std::unordered_map<uint64_t, uint32_t> reference;
  std::vector<uint64_t> live;
  uint64_t next_id = 1;
  for (int step = 0; step < 20000; ++step) {
    const bool add = live.empty() || std::uniform_int_distribution<int>(0, 99)(rng) < 55;
    if (add) {
      const uint64_t id = next_id++;
      const auto slot = static_cast<uint32_t>(rng() % 100000);
      index.insert(id, slot);
      reference[id] = slot;
      live.push_back(id);
    } else {
      const size_t k = rng() % live.size();
      index.erase(live[k]);
      reference.erase(live[k]);
      live[k] = live.back();
      live.pop_back();
    }
    if (step % 97 == 0) {
      ASSERT_EQ(index.size(), reference.size());
      for (const auto& [id, slot] : reference) ASSERT_EQ(index.find(id), slot) << "id " << id;
      for (uint64_t id = 1; id < next_id; id += 13) {
        if (reference.count(id) == 0) {
          ASSERT_EQ(index.find(id), IdIndex::kNone) << "id " << id;
        }
      }
    }
  }
  EXPECT_EQ(index.find(0), IdIndex::kNone);
  index.erase(next_id + 5);  // absent: no effect
  EXPECT_EQ(index.size(), reference.size());
}

}  // namespace
}  // namespace twocam::landmarks
