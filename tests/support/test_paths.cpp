#include "support/test_paths.h"

#include <unistd.h>

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

namespace {

/// The process's folder of test files, removed when the process ends unless
/// TWOCAM_KEEP_TEST_FILES is set (to look at them after a failure).
struct ProcessTempRoot {
  fs::path path =
      fs::temp_directory_path() / ("twocam_test_" + std::to_string(static_cast<long>(getpid())));
  ~ProcessTempRoot() {
    if (std::getenv("TWOCAM_KEEP_TEST_FILES") != nullptr) return;
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

}  // namespace

std::string makeTempDir(const std::string& name) {
  // One folder per process: two test runs at once (a Release and a sanitizer build, two
  // checkouts) must not write into each other's files.
  static ProcessTempRoot root;
  const fs::path p = root.path / name;
  fs::remove_all(p);
  fs::create_directories(p);
  return p.string();
}

}  // namespace twocam::test
