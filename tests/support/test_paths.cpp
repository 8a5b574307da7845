#include "support/test_paths.h"

#include <cstdlib>
#include <filesystem>

namespace twocam::test {

namespace fs = std::filesystem;

std::string sourceDir() {
  const char* env = std::getenv("TWOCAM_SOURCE_DIR");
  if (env != nullptr && *env != '\0') return env;
  return fs::current_path().string();
}

std::optional<std::string> sharedDataDir() {
  const fs::path p = fs::path(sourceDir()) / ".." / "shared" / "data";
  if (fs::is_directory(p)) return fs::canonical(p).string();
  return std::nullopt;
}

std::string makeTempDir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("twocam_test_" + name);
  fs::remove_all(p);
  fs::create_directories(p);
  return p.string();
}

}  // namespace twocam::test
