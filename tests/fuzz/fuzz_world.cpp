// libFuzzer harness: any bytes as a world file. Must return (no hang, crash or sanitizer report);
// a Status error is the expected outcome for nearly every input.
#include <cstddef>
#include <cstdint>
#include <string>

#include "sim/world_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  twocam::sim::World world;
  // A folder without texture files: image textures fail to resolve, everything else parses.
  (void)twocam::sim::parseWorld(text, "/nonexistent-twocam-fuzz", &world);
  return 0;
}
