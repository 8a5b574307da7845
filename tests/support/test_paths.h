#pragma once
/// Paths the tests need: the source tree (for worlds/) and the shared data folder.

#include <optional>
#include <string>

namespace twocam::test {

/// Project source folder (from TWOCAM_SOURCE_DIR, set by CTest).
std::string sourceDir();

/// ../shared/data next to the project, or nullopt when a user's clone lacks it.
std::optional<std::string> sharedDataDir();

/// A fresh, empty temporary folder for one test (removed and recreated), inside a folder of
/// this process that is removed at exit (kept when TWOCAM_KEEP_TEST_FILES is set).
std::string makeTempDir(const std::string& name);

}  // namespace twocam::test

/// Skips the current test with a message when ../shared/data is absent.
#define TWOCAM_REQUIRE_SHARED_DATA(var)                                               \
  const auto var##_opt = ::twocam::test::sharedDataDir();                             \
  if (!var##_opt) GTEST_SKIP() << "../shared/data is absent (users' clones lack it)"; \
  const std::string& var = *var##_opt
