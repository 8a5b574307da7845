#pragma once
/// Live landmark ids -> tracker slots, O(1) per insert, erase and lookup: an open-addressing hash
/// table (Fibonacci hashing, linear probing, backward-shift deletion, load factor at most 1/2).
/// The tracker creates and frees about a thousand landmarks per frame; std::unordered_map's node
/// allocations cost 15-20 % of the landmark update there (landmarks_bench, target load).

#include <cstddef>
#include <cstdint>
#include <vector>

namespace twocam::landmarks {

class IdIndex {
 public:
  static constexpr uint32_t kNone = UINT32_MAX;

  /// `id` must be non-zero and not present.
  void insert(uint64_t id, uint32_t slot) {
    if (2 * (size_ + 1) > keys_.size()) grow();
    size_t i = home(id);
    while (keys_[i] != 0) i = (i + 1) & mask_;
    keys_[i] = id;
    slots_[i] = slot;
    ++size_;
  }

  /// The slot of `id`, or kNone.
  [[nodiscard]] uint32_t find(uint64_t id) const {
    if (size_ == 0 || id == 0) return kNone;
    for (size_t i = home(id); keys_[i] != 0; i = (i + 1) & mask_) {
      if (keys_[i] == id) return slots_[i];
    }
    return kNone;
  }

  /// Removes `id` if present.
  void erase(uint64_t id) {
    if (size_ == 0 || id == 0) return;
    size_t i = home(id);
    while (keys_[i] != id) {
      if (keys_[i] == 0) return;
      i = (i + 1) & mask_;
    }
    // Backward shift: move later members of the probe run into the hole when their home slot
    // does not lie cyclically in (hole, j].
    for (size_t j = (i + 1) & mask_; keys_[j] != 0; j = (j + 1) & mask_) {
      const size_t k = home(keys_[j]);
      const bool stays = i <= j ? (i < k && k <= j) : (i < k || k <= j);
      if (stays) continue;
      keys_[i] = keys_[j];
      slots_[i] = slots_[j];
      i = j;
    }
    keys_[i] = 0;
    --size_;
  }

  [[nodiscard]] size_t size() const { return size_; }

 private:
  [[nodiscard]] size_t home(uint64_t id) const {
    return static_cast<size_t>((id * 0x9E3779B97F4A7C15ull) >> shift_);
  }
  void grow() {
    const std::vector<uint64_t> keys = std::move(keys_);
    const std::vector<uint32_t> slots = std::move(slots_);
    const size_t capacity = keys.empty() ? 1024 : 2 * keys.size();
    keys_.assign(capacity, 0);
    slots_.assign(capacity, kNone);
    mask_ = capacity - 1;
    shift_ = 64;
    for (size_t c = capacity; c > 1; c >>= 1) --shift_;
    size_ = 0;
    for (size_t i = 0; i < keys.size(); ++i) {
      if (keys[i] != 0) insert(keys[i], slots[i]);
    }
  }

  std::vector<uint64_t> keys_;  // 0 = empty (ids start at 1)
  std::vector<uint32_t> slots_;
  size_t mask_ = 0;
  int shift_ = 64;
  size_t size_ = 0;
};

}  // namespace twocam::landmarks
