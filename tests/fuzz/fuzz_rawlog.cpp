// libFuzzer harness: any bytes as a rawlog (uncompressed; MRPT's gzip reader passes plain files
// through). Opens it and reads every frame, as `twocam run` does. Must return.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include "io/rawlog.h"

namespace {
/// Whether the input holds an image stored inside the log (a CImage whose "external" flag, the
/// byte after its version, is 0). MRPT 2.5 decodes embedded JPEGs with libjpeg's default error
/// handler, which calls exit(1) on a corrupt one ("Not a JPEG file: ..."): a known limitation
/// (docs/recorded_data.md) that would stop every run, so such inputs are skipped.
bool hasEmbeddedImage(const std::string& bytes) {
  static const std::string kImage = "mrpt::img::CImage";
  for (size_t at = bytes.find(kImage); at != std::string::npos; at = bytes.find(kImage, at + 1)) {
    const size_t flag = at + kImage.size() + 1;
    if (flag >= bytes.size() || bytes[flag] != 1) return true;
  }
  return false;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (hasEmbeddedImage(std::string(reinterpret_cast<const char*>(data), size))) return 0;
  // One file per process (libFuzzer runs inputs one at a time in a process).
  static const std::string kPath =
      "/tmp/twocam_fuzz_rawlog_" + std::to_string(getpid()) + ".rawlog";
  std::FILE* f = std::fopen(kPath.c_str(), "wb");
  if (f == nullptr) return 0;
  std::fwrite(data, 1, size, f);
  std::fclose(f);
  std::unique_ptr<twocam::io::RawlogReader> reader;
  if (twocam::io::RawlogReader::open(kPath, &reader).isOk()) {
    twocam::io::LogFrame frame;
    twocam::Status status;
    constexpr int kMaxFrames = 100;  // a fuzz input holds a few frames at most
    for (int k = 0; k < kMaxFrames && reader->next(&frame, &status); ++k) {
    }
  }
  std::remove(kPath.c_str());
  return 0;
}
