#pragma once
/// The output folder of one run, written all or nothing.
///
/// RunWriter stages every file in a sibling temporary folder ("<parent>/.<name>.staging-XXXXXX",
/// same file system) and swaps it in at commit(): an earlier run's folder is replaced only by a
/// complete new one (an atomic exchange where the kernel has renameat2(RENAME_EXCHANGE), else two
/// renames with the old folder restored if the second fails) and is left intact, byte for byte,
/// when anything fails before. Without commit() the destructor removes the staging folder.
///
/// Before any work, begin() refuses an output folder that is one of the run's inputs, lies inside
/// an input folder, or contains an input (replacing it would delete the input); that is an existing
/// file; or that is an existing non-empty folder without `marker` (not an earlier run's folder:
/// replacing it would delete someone's files).

#include <memory>
#include <string>
#include <vector>

#include "common/image.h"
#include "common/status.h"
#include "io/json.h"

namespace twocam::io {

/// Writes `content` to "<path>.partial", then renames it onto `path`: a reader sees the old file
/// or the complete new one. The one atomic-file writer of TwoCam's outputs.
[[nodiscard]] Status writeFileAtomically(const std::string& path, const std::string& content);

class RunWriter {
 public:
  struct Options {
    /// File name whose presence marks an earlier run's folder that may be replaced.
    std::string marker = "metrics.json";
    /// Test seam (tests/tools/cli_test.cpp, via TWOCAM_TEST_FAIL_WRITE): writing this relative
    /// path fails as a full disk would, to check that a late failure keeps the earlier folder.
    std::string fail_write_for_tests;
  };

  /// Checks `output_dir` against `inputs` (paths the run reads; empty strings are ignored) and
  /// creates the staging folder (and output_dir's missing parents). Errors name the path.
  [[nodiscard]] static Status begin(const std::string& output_dir,
                                    const std::vector<std::string>& inputs,
                                    const Options& options,
                                    std::unique_ptr<RunWriter>* out);
  ~RunWriter();
  RunWriter(const RunWriter&) = delete;
  RunWriter& operator=(const RunWriter&) = delete;

  /// Stages a file at `relative_path` (sub-folders are created).
  [[nodiscard]] Status writeFile(const std::string& relative_path, const std::string& content);
  /// Stages JSON text (io/json.h toJsonText with `significant_digits`).
  [[nodiscard]] Status writeJson(const std::string& relative_path,
                                 const Json& value,
                                 int significant_digits);
  /// Stages a PNG of a grey image.
  [[nodiscard]] Status writePng(const std::string& relative_path, const ImageU8& image);
  /// Staging path for a file that another library writes itself (OctoMap's .bt); its parent
  /// folder exists. Check that file's own Status.
  [[nodiscard]] std::string stagedPath(const std::string& relative_path);

  /// Swaps the staged folder in at output_dir and removes what it replaced.
  [[nodiscard]] Status commit();

  [[nodiscard]] const std::string& outputDir() const { return output_dir_; }

 private:
  RunWriter(std::string output_dir, std::string staging_dir, Options options);
  [[nodiscard]] Status injectedFailure(const std::string& relative_path) const;

  std::string output_dir_;
  std::string staging_dir_;
  Options options_;
  bool committed_ = false;
};

}  // namespace twocam::io
