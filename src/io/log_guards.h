#pragma once
/// Guards of the rawlog reader against corrupt logs (internal to src/io): a cap on single
/// allocations while MRPT deserialises an object (the replaced global operator new lives in
/// log_guards.cpp), and a look-ahead stream so that sizes are checked before MRPT allocates by
/// them.

#include <mrpt/io/CStream.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

namespace twocam::io::internal {

/// Largest single allocation while MRPT deserialises one object of a log, 0 = no limit. MRPT
/// reads a length (string, vector, image) from the archive and allocates by it before reading
/// the data, so one changed byte asked for gigabytes (zero-filled: all memory). 256 MiB is far
/// above any real observation (a 4096 x 3072 colour image is 36 MiB).
constexpr size_t kMaxObjectAllocationBytes = size_t{256} << 20;
/// The calling thread's cap on one allocation, 0 = no limit.
size_t allocationCapBytes();

/// Sets the calling thread's cap for its lifetime. The thread_local behind it lives in
/// log_guards.cpp only: an `extern thread_local` read through GCC's TLS wrapper from another
/// library was reported by UBSan as a store to a null pointer.
class AllocationCap {
 public:
  explicit AllocationCap(size_t bytes);
  ~AllocationCap();
  AllocationCap(const AllocationCap&) = delete;
  AllocationCap& operator=(const AllocationCap&) = delete;

 private:
  size_t saved_;
};
/// A read-only stream over another with look-ahead: peek() reads bytes ahead without consuming
/// them, so that sizes can be checked before MRPT's deserialisers allocate by them. Every image
/// serialised in the stream is filtered (embedded_images.h: a JPEG is decoded here and handed to
/// MRPT as raw pixels, a bad one as a rejected image) before MRPT reads the first byte of its
/// class name's "Image", so that MRPT never decodes a JPEG itself.
class PeekableStream : public mrpt::io::CStream {
 public:
  explicit PeekableStream(mrpt::io::CStream& source) : source_(source) {}

  size_t Read(void* buffer, size_t count) override;
  size_t Write(const void* /*buffer*/, size_t /*count*/) override { return 0; }
  uint64_t Seek(int64_t /*offset*/, TSeekOrigin /*origin*/) override {
    throw std::runtime_error("rawlog reader: seek not supported");
  }
  uint64_t getTotalBytesCount() const override { return source_.getTotalBytesCount(); }
  uint64_t getPosition() const override { return position_; }

  /// The next `count` bytes (fewer at the end of the stream), left unread.
  std::string peek(size_t count);

  /// The reason of the last image the filter rejected since the previous call, if any.
  std::optional<std::string> takeRejection() { return std::exchange(rejection_, std::nullopt); }

 private:
  /// Makes ahead_ hold at least `size` bytes; false if the source ends first.
  bool fill(size_t size);
  /// Filters the images whose "Image" starts before ahead_[end], after making ahead_ hold the
  /// bytes up to `end` (fewer at the end of the stream).
  void prepare(size_t end);

  mrpt::io::CStream& source_;
  std::string ahead_;
  size_t ahead_pos_ = 0;   // next byte to hand out
  size_t filtered_ = 0;    // "Image" texts starting before ahead_[filtered_] are handled
  uint64_t position_ = 0;  // bytes handed out
  std::optional<std::string> rejection_;
};

/// A size in the log that the log itself does not allow: an error of the frame being read.
class BadSizeError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Largest image a log may declare before the stereo rig is known, or in logs not written by
/// TwoCam [px per side]; TwoCam's own depth images have the rig's size.
constexpr uint32_t kMaxForeignImageSidePx = 16384;
constexpr uint64_t kMaxForeignImagePixels = uint64_t{1} << 26;  // 64 Mpx, 128 MB of uint16

/// MRPT 2.5's serialisation of CObservation3DRangeScan (version 10) up to the range image size,
/// as TwoCam's writer produces it (no 3-D points):
///   0xa2 "mrpt::obs::CObservation3DRangeScan" 0x0a | float maxRange |
///   0x94 "mrpt::poses::CPose3D" 0x03 12 x double 0x88 | bool hasPoints3D = 0 |
///   bool hasRangeImage = 1 | float rangeUnits | uint32 rows | uint32 cols | rows x cols x uint16
/// Returns the (rows, cols) such an object declares, or nullopt if the next object is anything
/// else (other classes and layouts are left to MRPT).
std::optional<std::pair<uint32_t, uint32_t>> peekRangeImageSize(PeekableStream& stream);

}  // namespace twocam::io::internal
