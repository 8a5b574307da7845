#include "support/command.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace twocam::test {

std::string readFile(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

CommandResult runCommand(const std::string& command_line) {
  const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const std::string name =
      info != nullptr ? std::string(info->test_suite_name()) + "_" + info->name() : "no_test";
  const std::string stem = (std::filesystem::temp_directory_path() /
                            ("twocam_cmd_" + name + "_" + std::to_string(getpid())))
                               .string();
  const int rc =
      std::system((command_line + " > " + stem + ".txt 2> " + stem + ".err.txt").c_str());
  CommandResult r;
  r.exit_code = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  r.out = readFile(stem + ".txt");
  r.err = readFile(stem + ".err.txt");
  std::error_code ec;
  std::filesystem::remove(stem + ".txt", ec);
  std::filesystem::remove(stem + ".err.txt", ec);
  return r;
}

}  // namespace twocam::test
