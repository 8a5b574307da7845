#pragma once
/// Images stored inside a rawlog (internal to src/io). MRPT 2.5 decodes a JPEG stored in a log
/// while it deserialises the image (CImage::serializeFrom, inside ReadObject; only externally
/// stored images are loaded later, on first access), with libjpeg's default error handler, which
/// calls exit(1) on a corrupt one; and it reads a raw grey image's bytes by the size the log
/// declares, past its buffer when that is larger than the image. So the reader's look-ahead
/// stream (PeekableStream) rewrites every serialised CImage before MRPT reads it:
///   - a JPEG is decoded here with OpenCV (which reports errors instead of exiting) and handed to
///     MRPT as the raw grey image it decodes to: MRPT never sees a JPEG, nothing is decoded twice;
///   - an image that cannot be decoded, or whose declared sizes disagree, becomes an externally
///     stored image whose "file name" says why (rejectedImageReason), which the reader reports as
///     an error of that frame;
///   - anything else (external images, raw colour or grey images with consistent sizes) is left
///     as it is.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <utility>

namespace twocam::io::internal {

/// Makes the look-ahead buffer hold at least `size` bytes; false if the log ends first.
using FillFunction = std::function<bool(size_t size)>;

/// Handles the text "Image" at bytes[at] of the look-ahead buffer: when it ends the class name of
/// a serialised image (any name MRPT's class registry resolves to mrpt::img::CImage, such as
/// "CImage" or "CMRPTImage", in the current or the pre-0.5.5 header format), the image's data
/// after its name is rewritten in place as above. Returns the index from which to look for the
/// next "Image": past the rewritten data, or at + 1. A rejected image's reason also goes to
/// *rejection: when the rest of the object no longer parses (a size field was wrong, so the data
/// that follows is not where MRPT looks), the reader reports that instead of MRPT's message.
size_t filterEmbeddedImage(std::string* bytes,
                           size_t at,
                           const FillFunction& fill,
                           std::optional<std::string>* rejection);

/// The reason the filter stored for an image it rejected, or nullopt for any other external file
/// name (a real file name holds no NUL byte; the reason's marker starts with one).
std::optional<std::string> rejectedImageReason(const std::string& external_file);

/// Width and height a JPEG declares in its frame header (SOFn), or nullopt if the bytes are not
/// a JPEG or end before one.
std::optional<std::pair<uint32_t, uint32_t>> jpegFrameSize(const std::string& jpeg);

}  // namespace twocam::io::internal
