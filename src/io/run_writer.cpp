#include "io/run_writer.h"

#include <fcntl.h>
#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <opencv2/core/mat.hpp>
#include <opencv2/imgcodecs.hpp>

namespace twocam::io {
namespace {

namespace fs = std::filesystem;

/// Absolute, normalised form of a path that may not exist yet (symbolic links of its existing
/// part resolved), for comparing outputs with inputs.
fs::path canonicalOf(const std::string& path) {
  std::error_code ec;
  fs::path p = fs::weakly_canonical(fs::absolute(path, ec), ec);
  if (ec) p = fs::absolute(path).lexically_normal();
  // "dir/" and "dir" name the same folder.
  if (!p.has_filename() && p.has_parent_path()) p = p.parent_path();
  return p;
}

/// Whether `inner` is `outer` or lies below it.
bool within(const fs::path& inner, const fs::path& outer) {
  auto o = outer.begin(), i = inner.begin();
  for (; o != outer.end(); ++o, ++i) {
    if (i == inner.end() || *i != *o) return false;
  }
  return true;
}

}  // namespace

Status writeFileAtomically(const std::string& path, const std::string& content) {
  const std::string tmp = path + ".partial";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) return Status::error(tmp + ": cannot write");
    out << content;
    out.flush();
    if (!out.good()) return Status::error(tmp + ": write failed");
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    return Status::error(path + ": cannot rename into place (" + ec.message() + ")");
  }
  return Status::ok();
}

RunWriter::RunWriter(std::string output_dir, std::string staging_dir, Options options)
    : output_dir_(std::move(output_dir)),
      staging_dir_(std::move(staging_dir)),
      options_(std::move(options)) {}

RunWriter::~RunWriter() {
  if (committed_ || staging_dir_.empty()) return;
  std::error_code ec;
  fs::remove_all(staging_dir_, ec);
}

Status RunWriter::begin(const std::string& output_dir,
                        const std::vector<std::string>& inputs,
                        const Options& options,
                        std::unique_ptr<RunWriter>* out) {
  if (output_dir.empty()) return Status::error("the output folder is an empty path");
  const fs::path target = canonicalOf(output_dir);
  for (const std::string& input : inputs) {
    if (input.empty()) continue;
    const fs::path in = canonicalOf(input);
    if (within(in, target)) {
      return Status::error(output_dir + ": the output folder " +
                           (in == target ? "is" : "contains") + " the input " + input +
                           " (replacing the folder would delete it); choose another folder");
    }
    std::error_code ec;
    if (fs::is_directory(in, ec) && within(target, in)) {
      return Status::error(output_dir + ": the output folder is inside the input folder " + input +
                           "; choose another folder");
    }
  }
  std::error_code ec;
  const fs::file_status st = fs::status(target, ec);
  if (fs::exists(st)) {
    if (!fs::is_directory(st)) {
      return Status::error(output_dir + ": exists and is not a folder");
    }
    const bool empty = fs::is_empty(target, ec);
    if (ec) return Status::error(output_dir + ": cannot read the folder (" + ec.message() + ")");
    if (!empty && !fs::exists(target / options.marker, ec)) {
      return Status::error(output_dir + ": exists, is not empty and holds no " + options.marker +
                           " (not an earlier run's folder, which a run replaces as a whole); "
                           "choose a new or empty folder");
    }
  }
  const fs::path parent = target.parent_path();
  fs::create_directories(parent, ec);
  if (!fs::is_directory(parent, ec)) {
    return Status::error(output_dir + ": cannot create the folder " + parent.string());
  }
  std::string pattern = (parent / ("." + target.filename().string() + ".staging-XXXXXX")).string();
  if (::mkdtemp(pattern.data()) == nullptr) {
    return Status::error(output_dir + ": cannot create a staging folder in " + parent.string() +
                         " (" + std::strerror(errno) + "); is it writable?");
  }
  // mkdtemp makes the folder private (0700); a run folder gets the usual mode (0777 - umask).
  const mode_t mask = ::umask(0);
  ::umask(mask);
  ::chmod(pattern.c_str(), 0777 & ~mask);
  out->reset(new RunWriter(target.string(), pattern, options));
  return Status::ok();
}

Status RunWriter::injectedFailure(const std::string& relative_path) const {
  if (!options_.fail_write_for_tests.empty() && relative_path == options_.fail_write_for_tests) {
    return Status::error((fs::path(output_dir_) / relative_path).string() +
                         ": cannot write (injected failure for tests)");
  }
  return Status::ok();
}

std::string RunWriter::stagedPath(const std::string& relative_path) {
  const fs::path p = fs::path(staging_dir_) / relative_path;
  std::error_code ec;
  fs::create_directories(p.parent_path(), ec);
  return p.string();
}

Status RunWriter::writeFile(const std::string& relative_path, const std::string& content) {
  if (Status s = injectedFailure(relative_path); !s) return s;
  return writeFileAtomically(stagedPath(relative_path), content);
}

Status RunWriter::writeJson(const std::string& relative_path,
                            const Json& value,
                            int significant_digits) {
  return writeFile(relative_path, toJsonText(value, significant_digits));
}

Status RunWriter::writePng(const std::string& relative_path, const ImageU8& image) {
  if (image.empty()) return Status::error(relative_path + ": empty image");
  const cv::Mat mat(image.height,
                    image.width,
                    CV_8UC1,
                    const_cast<uint8_t*>(image.data.data()),
                    static_cast<size_t>(image.width));
  std::vector<uchar> png;
  if (!cv::imencode(".png", mat, png)) return Status::error(relative_path + ": cannot encode PNG");
  return writeFile(relative_path, std::string(png.begin(), png.end()));
}

Status RunWriter::commit() {
  std::error_code ec;
  const bool exists = fs::exists(output_dir_, ec);
  if (!exists) {
    fs::rename(staging_dir_, output_dir_, ec);
    if (ec)
      return Status::error(output_dir_ + ": cannot move the output into place (" + ec.message() +
                           ")");
    committed_ = true;
    return Status::ok();
  }
  // Atomic swap: afterwards staging_dir_ holds the earlier run, which is removed.
  if (::renameat2(AT_FDCWD, staging_dir_.c_str(), AT_FDCWD, output_dir_.c_str(), RENAME_EXCHANGE) ==
      0) {
    fs::remove_all(staging_dir_, ec);
    committed_ = true;
    return Status::ok();
  }
  // No exchange on this file system: move the earlier run aside, the new one in, and restore the
  // earlier one if that fails.
  const std::string aside = staging_dir_ + ".old";
  fs::rename(output_dir_, aside, ec);
  if (ec)
    return Status::error(output_dir_ + ": cannot replace the earlier run (" + ec.message() + ")");
  fs::rename(staging_dir_, output_dir_, ec);
  if (ec) {
    std::error_code ec2;
    fs::rename(aside, output_dir_, ec2);
    return Status::error(output_dir_ + ": cannot move the output into place (" + ec.message() +
                         ")");
  }
  fs::remove_all(aside, ec);
  committed_ = true;
  return Status::ok();
}

}  // namespace twocam::io
