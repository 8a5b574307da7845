// libFuzzer harness: any bytes as a run config (twocam run --config). Must return.
#include <cstddef>
#include <cstdint>
#include <string>

#include "pipeline/config.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  twocam::pipeline::PipelineConfig config;
  if (twocam::pipeline::parseConfigYaml(text, &config).isOk()) (void)config.validate();
  return 0;
}
