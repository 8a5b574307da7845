#include "io/log_guards.h"

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <new>
#include <string_view>

#include "io/embedded_images.h"

namespace twocam::io::internal {

namespace {
thread_local size_t t_allocation_cap_bytes = 0;  // 0 = no limit
}  // namespace

size_t allocationCapBytes() { return t_allocation_cap_bytes; }

AllocationCap::AllocationCap(size_t bytes) : saved_(t_allocation_cap_bytes) {
  t_allocation_cap_bytes = bytes;
}
AllocationCap::~AllocationCap() { t_allocation_cap_bytes = saved_; }

namespace {
constexpr size_t kKeepBehindBytes = 128;  // longest object header before a class name's "Image"
constexpr size_t kCompactAboveBytes = size_t{1} << 20;
constexpr size_t kReadChunkBytes = size_t{64} << 10;
constexpr size_t kMaxReadChunkBytes = size_t{1} << 20;
const char* const kImageText = "Image";
constexpr size_t kImageTextChars = 5;
}  // namespace

bool PeekableStream::fill(size_t size) {
  while (ahead_.size() < size) {
    const size_t want =
        std::min(std::max(size - ahead_.size(), kReadChunkBytes), kMaxReadChunkBytes);
    const size_t have = ahead_.size();
    ahead_.resize(have + want);
    const size_t got = source_.Read(ahead_.data() + have, want);
    ahead_.resize(have + got);
    if (got == 0) return false;
  }
  return true;
}

void PeekableStream::prepare(size_t end) {
  const FillFunction fill_ahead = [this](size_t size) { return fill(size); };
  while (true) {
    fill(end + kImageTextChars - 1);  // an "Image" that starts before `end` is whole
    const size_t stop = std::min(end, ahead_.size());
    if (filtered_ >= stop) return;
    // Only the bytes about to be handed out: the look-ahead can be much longer.
    const std::string_view window =
        std::string_view(ahead_).substr(filtered_, stop - filtered_ + kImageTextChars - 1);
    const size_t hit = window.find(kImageText);
    if (hit == std::string_view::npos || filtered_ + hit >= stop) {
      filtered_ = stop;
      return;
    }
    filtered_ = filterEmbeddedImage(&ahead_, filtered_ + hit, fill_ahead, &rejection_);
  }
}

size_t PeekableStream::Read(void* buffer, size_t count) {
  prepare(ahead_pos_ + count);
  const size_t n = std::min(count, ahead_.size() - ahead_pos_);
  if (n > 0) std::memcpy(buffer, ahead_.data() + ahead_pos_, n);
  ahead_pos_ += n;
  position_ += n;
  if (ahead_pos_ > kCompactAboveBytes + kKeepBehindBytes) {
    const size_t drop = ahead_pos_ - kKeepBehindBytes;
    ahead_.erase(0, drop);
    ahead_pos_ -= drop;
    filtered_ -= drop;
  }
  return n;
}

std::string PeekableStream::peek(size_t count) {
  prepare(ahead_pos_ + count);
  return ahead_.substr(ahead_pos_, count);
}

std::optional<std::pair<uint32_t, uint32_t>> peekRangeImageSize(PeekableStream& stream) {
  static const std::string kClass = "mrpt::obs::CObservation3DRangeScan";
  static const std::string kPose = "mrpt::poses::CPose3D";
  const size_t pose_at = 1 + kClass.size() + 1 + 4;
  const size_t after_pose = pose_at + 1 + kPose.size() + 1 + 12 * 8 + 1;
  const size_t size_at = after_pose + 2 + 4;
  const std::string b = stream.peek(size_at + 8);
  if (b.size() < size_at + 8) return std::nullopt;
  const auto byte = [&](size_t i) { return static_cast<uint8_t>(b[i]); };
  if (byte(0) != (0x80 | kClass.size()) || b.compare(1, kClass.size(), kClass) != 0 ||
      byte(1 + kClass.size()) != 10) {
    return std::nullopt;
  }
  if (byte(pose_at) != (0x80 | kPose.size()) || b.compare(pose_at + 1, kPose.size(), kPose) != 0 ||
      byte(after_pose - 1) != 0x88) {
    return std::nullopt;
  }
  if (byte(after_pose) != 0 || byte(after_pose + 1) != 1) return std::nullopt;
  uint32_t rows = 0;
  uint32_t cols = 0;
  std::memcpy(&rows, b.data() + size_at, 4);  // MRPT archives are little-endian
  std::memcpy(&cols, b.data() + size_at + 4, 4);
  return std::make_pair(rows, cols);
}

}  // namespace twocam::io::internal

// The global operator new, replaced so that the cap above can refuse a request (the standard
// allows a program to replace it). Without a cap it behaves as the default.
void* operator new(std::size_t bytes) {
  const size_t cap = twocam::io::internal::allocationCapBytes();
  if (cap != 0 && bytes > cap) throw std::bad_alloc();
  void* p = std::malloc(bytes == 0 ? 1 : bytes);
  while (p == nullptr) {
    std::new_handler handler = std::get_new_handler();
    if (handler == nullptr) throw std::bad_alloc();
    handler();
    p = std::malloc(bytes == 0 ? 1 : bytes);
  }
  return p;
}
void* operator new[](std::size_t bytes) { return operator new(bytes); }
void* operator new(std::size_t bytes, const std::nothrow_t& /*tag*/) noexcept {
  try {
    return operator new(bytes);
  } catch (const std::bad_alloc&) {
    return nullptr;
  }
}
void* operator new[](std::size_t bytes, const std::nothrow_t& tag) noexcept {
  return operator new(bytes, tag);
}
// The aligned forms stay the library's (their own allocate/free pair).
// Matching deletes (std::free), also needed where a sanitizer supplies its own operators. GCC
// cannot see that the operator new above allocates with std::malloc.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#endif
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t /*bytes*/) noexcept { std::free(p); }
void operator delete(void* p, const std::nothrow_t& /*tag*/) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t /*bytes*/) noexcept { std::free(p); }
void operator delete[](void* p, const std::nothrow_t& /*tag*/) noexcept { std::free(p); }
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif
