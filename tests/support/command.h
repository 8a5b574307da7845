#pragma once
/// Running a command line in tests: exit status, stdout and stderr.

#include <string>

namespace twocam::test {

struct CommandResult {
  int exit_code = -1;  ///< -1 when the command did not exit normally
  std::string out;     ///< stdout
  std::string err;     ///< stderr
};

/// Runs `command_line` through the shell, capturing stdout and stderr in files named after the
/// current GoogleTest test and this process (CTest runs a binary's tests in parallel).
CommandResult runCommand(const std::string& command_line);

/// The whole file, or "" when it cannot be read.
std::string readFile(const std::string& path);

}  // namespace twocam::test
