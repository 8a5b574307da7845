#include "io/embedded_images.h"

#include <mrpt/img/CImage.h>
#include <mrpt/io/CMemoryStream.h>
#include <mrpt/rtti/CObject.h>
#include <mrpt/serialization/CArchive.h>

#include <algorithm>
#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <vector>

#include "common/quiet_stderr.h"
#include "io/log_guards.h"

namespace twocam::io::internal {

namespace {

/// Marker of a rejected image's "file name": NUL first, which no file name holds.
const std::string& rejectedPrefix() {
  static const std::string kPrefix("\0twocam: ", 9);
  return kPrefix;
}

/// MRPT's limit on a class name (CArchive::internal_ReadObjectHeader).
constexpr size_t kMaxClassNameChars = 120;
/// Largest JPEG payload accepted (same cap as any single allocation of one object).
constexpr uint32_t kMaxJpegBytes = static_cast<uint32_t>(kMaxObjectAllocationBytes);
/// Most pixels a JPEG may declare per byte of its data. A Huffman-coded JPEG spends at least one
/// bit on each 8 x 8 block's DC term (512 pixels a byte for grey), so a header declaring far more
/// is corrupt; without this bound a few hundred bytes could ask for a 64 Mpx decode, and a log
/// of such images for minutes of work.
constexpr uint64_t kMaxJpegPixelsPerByte = 1024;

/// Where the data of a serialised image starts: its version field.
struct ImageHeader {
  size_t version_at = 0;
  bool old_format = false;  // pre-0.5.5 header: int32 version, no end flag
  bool operator==(const ImageHeader& o) const {
    return version_at == o.version_at && old_format == o.old_format;
  }
};

bool namesImage(const std::string& name) {
  const mrpt::rtti::TRuntimeClassId* id = mrpt::rtti::findRegisteredClass(name);
  return id != nullptr && id == CLASS_ID(mrpt::img::CImage);
}

/// Object headers whose class name, as MRPT reads it (up to its first NUL), ends with the
/// "Image" at `at`: [0x80 | n][n name bytes][uint8 version] or [n][0 0 0][n name bytes][int32
/// version]. Several only in crafted bytes.
std::vector<ImageHeader> headersAt(std::string* bytes, size_t at, const FillFunction& fill) {
  constexpr size_t kSuffixChars = 5;  // "Image"
  const size_t name_end = at + kSuffixChars;
  const bool more = fill(name_end + 1);
  const std::string& b = *bytes;
  const bool nul_after = more && b[name_end] == '\0';
  std::vector<ImageHeader> found;
  const auto consider = [&](size_t s, size_t n, bool old_format) {
    if (n > kMaxClassNameChars || s + n < name_end) return;
    if (s + n > name_end && !nul_after) return;
    if (!namesImage(b.substr(s, name_end - s))) return;
    const ImageHeader h{s + n, old_format};
    if (std::find(found.begin(), found.end(), h) == found.end()) found.push_back(h);
  };
  const size_t lowest = name_end > kMaxClassNameChars ? name_end - kMaxClassNameChars : 0;
  for (size_t s = at + 1; s-- > lowest;) {
    if (b[s] == '\0') break;  // the name would end before "Image"
    if (s < 1) break;
    const auto lead = static_cast<uint8_t>(b[s - 1]);
    if ((lead & 0x80) != 0) consider(s, lead & 0x7F, false);
    if (s >= 4 && lead == 0 && b[s - 2] == '\0' && b[s - 3] == '\0') {
      const auto n = static_cast<uint8_t>(b[s - 4]);
      if ((n & 0x80) == 0) consider(s, n, true);
    }
  }
  return found;
}

/// Little-endian fields of the buffer, read at a cursor that fills the buffer as it goes.
class Cursor {
 public:
  Cursor(std::string* bytes, size_t at, const FillFunction& fill)
      : bytes_(bytes), at_(at), fill_(fill) {}
  template <typename T>
  bool get(T* value) {
    if (!fill_(at_ + sizeof(T))) return false;
    std::memcpy(value, bytes_->data() + at_, sizeof(T));  // MRPT archives are little-endian
    at_ += sizeof(T);
    return true;
  }
  size_t at() const { return at_; }
  void skip(size_t n) { at_ += n; }

 private:
  std::string* bytes_;
  size_t at_;
  const FillFunction& fill_;
};

/// MRPT's serialisation of an image, without its class-name header and end flag: the version
/// (as in `old_format`) and the data.
std::string imageData(const mrpt::img::CImage& image, bool old_format) {
  mrpt::io::CMemoryStream stream;
  auto arch = mrpt::serialization::archiveFrom(stream);
  arch << image;
  const std::string all(static_cast<const char*>(stream.getRawBufferData()),
                        static_cast<size_t>(stream.getTotalBytesCount()));
  const size_t version_at = 1 + (static_cast<uint8_t>(all[0]) & 0x7F);
  std::string data = all.substr(version_at + 1, all.size() - version_at - 2);
  if (old_format) {
    const int32_t version = static_cast<uint8_t>(all[version_at]);
    return std::string(reinterpret_cast<const char*>(&version), 4) + data;
  }
  return all[version_at] + data;
}

std::string rejectedData(const std::string& reason, bool old_format) {
  mrpt::img::CImage image;
  image.setExternalStorage(rejectedPrefix() + reason);
  return imageData(image, old_format);
}

/// Bytes per pixel of MRPT's PixelDepth values (OpenCV's depth codes); 0 for others.
size_t bytesPerPixel(int32_t depth) {
  switch (depth) {
    case CV_8U:
    case CV_8S:
      return 1;
    case CV_16U:
    case CV_16S:
      return 2;
    case CV_32S:
    case CV_32F:
      return 4;
    case CV_64F:
      return 8;
    default:
      return 0;
  }
}

/// Decodes a JPEG to grey, or says why it cannot.
std::optional<std::string> decodeJpeg(const std::string& jpeg, cv::Mat* grey) {
  std::ostringstream why;
  if (jpeg.size() < 3 || static_cast<uint8_t>(jpeg[0]) != 0xFF ||
      static_cast<uint8_t>(jpeg[1]) != 0xD8) {
    why << "embedded image is not a JPEG (" << jpeg.size() << " bytes)";
    return why.str();
  }
  const auto size = jpegFrameSize(jpeg);
  if (!size) {
    why << "embedded JPEG has no frame header (" << jpeg.size() << " bytes, corrupt log)";
    return why.str();
  }
  const auto [width, height] = *size;
  if (width == 0 || height == 0 || width > kMaxForeignImageSidePx ||
      height > kMaxForeignImageSidePx || uint64_t{width} * height > kMaxForeignImagePixels) {
    why << "embedded JPEG declares " << width << "x" << height << " pixels, outside 1 to "
        << kMaxForeignImageSidePx << " per side and " << kMaxForeignImagePixels
        << " in all (corrupt log)";
    return why.str();
  }
  if (uint64_t{width} * height > kMaxJpegPixelsPerByte * jpeg.size()) {
    why << "embedded JPEG declares " << width << "x" << height << " pixels in " << jpeg.size()
        << " bytes, more than a JPEG holds (corrupt log)";
    return why.str();
  }
  {
    const QuietStderr quiet;  // libjpeg prints warnings such as "Corrupt JPEG data: ..."
    try {
      const cv::Mat raw(1, static_cast<int>(jpeg.size()), CV_8UC1, const_cast<char*>(jpeg.data()));
      *grey = cv::imdecode(raw, cv::IMREAD_GRAYSCALE | cv::IMREAD_IGNORE_ORIENTATION);
    } catch (const cv::Exception&) {
      grey->release();
    }
  }
  if (grey->empty()) {
    why << "embedded JPEG (" << jpeg.size() << " bytes) cannot be decoded (corrupt log)";
    return why.str();
  }
  return std::nullopt;
}

/// Rewrites the image whose version field is at h.version_at; returns the index past the data
/// that is final (rewritten or checked).
size_t rewriteImage(std::string* bytes,
                    const ImageHeader& h,
                    const FillFunction& fill,
                    std::optional<std::string>* rejection) {
  Cursor c(bytes, h.version_at, fill);
  uint32_t version = 0;
  if (h.old_format) {
    int32_t v = 0;
    if (!c.get(&v) || v < 0 || v >= 255) return h.version_at;  // MRPT rejects it
    version = static_cast<uint32_t>(v);
  } else {
    uint8_t v = 0;
    if (!c.get(&v)) return h.version_at;
    version = v;
  }
  const auto replace = [&](size_t end, const std::string& data) {
    bytes->replace(h.version_at, end - h.version_at, data);
    return h.version_at + data.size();
  };
  const auto reject = [&](size_t end, const std::string& reason) {
    *rejection = reason;
    fill(end);
    return replace(std::min(end, bytes->size()), rejectedData(reason, h.old_format));
  };
  std::ostringstream why;
  bool jpeg = false;
  if (version == 0) {
    uint32_t width = 0, height = 0, channels = 0, length = 0;
    uint8_t origin = 0;
    if (!c.get(&width) || !c.get(&height) || !c.get(&channels) || !c.get(&origin) ||
        !c.get(&length))
      return h.version_at;
    if ((channels == 1 || channels == 3) && uint64_t{width} * height * channels == length)
      return c.at();
    why << "embedded image declares " << length << " bytes for " << width << "x" << height
        << " pixels of " << channels << " channels (corrupt log)";
    return reject(c.at() + std::min<size_t>(length, kMaxJpegBytes), why.str());
  }
  if (version == 1) {
    jpeg = true;
  } else if (version >= 2 && version <= 9) {
    if (version >= 6) {
      uint8_t external = 0;
      if (!c.get(&external)) return h.version_at;
      if (external == 1) return c.at();
      if (external != 0)
        return reject(c.at(), "corrupt log: an image's external-storage flag is not 0 or 1");
    }
    uint8_t color = 0;
    if (!c.get(&color)) return h.version_at;
    if (color == 0) {
      int32_t width = 0, height = 0, origin = 0, size = 0, depth = CV_8U;
      if (!c.get(&width) || !c.get(&height) || !c.get(&origin) || !c.get(&size))
        return h.version_at;
      if (version >= 9 && !c.get(&depth)) return h.version_at;
      const size_t pixel_bytes = bytesPerPixel(depth);
      if (width >= 0 && height >= 0 && pixel_bytes > 0 &&
          uint64_t(width) * uint64_t(height) * pixel_bytes == static_cast<uint32_t>(size))
        return c.at();
      why << "embedded grey image declares " << static_cast<uint32_t>(size) << " bytes for "
          << width << "x" << height << " pixels of depth " << depth << " (corrupt log)";
      // MRPT would read that many bytes (none when ZIP-compressed: it refuses those).
      return reject(c.at() + std::min<size_t>(static_cast<uint32_t>(size), kMaxJpegBytes),
                    why.str());
    }
    jpeg = true;
    if (version >= 7) {
      int32_t width = 0, height = 0;
      if (!c.get(&width) || !c.get(&height)) return h.version_at;
      jpeg = width >= 1 && height >= 1;  // else raw rows (read by size) or an empty image
    }
  }
  if (!jpeg) return c.at();  // nothing MRPT decodes
  uint32_t length = 0;
  if (!c.get(&length)) return h.version_at;
  if (length > kMaxJpegBytes) {
    why << "embedded JPEG declares " << length << " bytes, above the limit of "
        << (kMaxJpegBytes >> 20) << " MiB (corrupt log)";
    return reject(c.at(), why.str());
  }
  if (!fill(c.at() + length))
    return reject(bytes->size(), "embedded JPEG is cut short (truncated log)");
  cv::Mat grey;
  if (auto reason = decodeJpeg(bytes->substr(c.at(), length), &grey))
    return reject(c.at() + length, *reason);
  const mrpt::img::CImage image(grey, mrpt::img::SHALLOW_COPY);
  return replace(c.at() + length, imageData(image, h.old_format));
}

}  // namespace

size_t filterEmbeddedImage(std::string* bytes,
                           size_t at,
                           const FillFunction& fill,
                           std::optional<std::string>* rejection) {
  const std::vector<ImageHeader> headers = headersAt(bytes, at, fill);
  if (headers.empty()) return at + 1;
  if (headers.size() > 1) {
    // Crafted bytes that MRPT may read as either of several images: none of them resolves once
    // the name is broken, so MRPT reports an unknown class instead.
    (*bytes)[at] = '?';
    return at + 1;
  }
  return std::max(at + 1, rewriteImage(bytes, headers.front(), fill, rejection));
}

std::optional<std::string> rejectedImageReason(const std::string& external_file) {
  if (external_file.compare(0, rejectedPrefix().size(), rejectedPrefix()) != 0) return std::nullopt;
  return external_file.substr(rejectedPrefix().size());
}

std::optional<std::pair<uint32_t, uint32_t>> jpegFrameSize(const std::string& jpeg) {
  const auto byte = [&](size_t i) { return static_cast<uint8_t>(jpeg[i]); };
  if (jpeg.size() < 2 || byte(0) != 0xFF || byte(1) != 0xD8) return std::nullopt;
  size_t i = 2;
  while (i + 4 <= jpeg.size()) {
    if (byte(i) != 0xFF) return std::nullopt;
    const uint8_t marker = byte(i + 1);
    if (marker == 0xFF) {  // fill byte
      ++i;
      continue;
    }
    i += 2;
    if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD8)) continue;  // no length field
    if (marker == 0xD9 || marker == 0xDA) return std::nullopt;  // end or scan before a frame
    const size_t length = (size_t{byte(i)} << 8) | byte(i + 1);
    if (length < 2 || i + length > jpeg.size()) return std::nullopt;
    const bool frame =
        marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
    if (frame) {
      if (length < 7) return std::nullopt;
      const uint32_t height = (uint32_t{byte(i + 3)} << 8) | byte(i + 4);
      const uint32_t width = (uint32_t{byte(i + 5)} << 8) | byte(i + 6);
      return std::make_pair(width, height);
    }
    i += length;
  }
  return std::nullopt;
}

}  // namespace twocam::io::internal
