// libFuzzer harness: any bytes as a rawlog (uncompressed; MRPT's gzip reader passes plain files
// through). Opens it and reads every frame, as `twocam run` does. Must return: images stored
// inside the log included (the reader decodes their JPEGs itself, MRPT's libjpeg would exit).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include "io/rawlog.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
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
