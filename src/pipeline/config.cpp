#include "pipeline/config.h"

#include <mrpt/containers/yaml.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <system_error>
#include <type_traits>
#include <utility>
#include <vector>

#include "pipeline/config_schema.h"
#include "yaml/yaml_text.h"

namespace twocam::pipeline {

frontend::FrontendOptions pipelineFrontendDefaults() {
  frontend::FrontendOptions options;
  options.harris.target_count = 2500;
  options.harris.max_corners = 5000;     // 2x the target, as in HarrisOptions
  options.sad.row_support = true;        // the consistency policy's confirmation reads it
  options.sad.birchfield_tomasi = true;  // sampling-insensitive: docs/frontend.md
  return options;
}
namespace {

using yaml::editDistance;
using yaml::mrptMessage;
using yaml::parseYaml;

using Yaml = mrpt::containers::yaml;
using Node = Yaml::node_t;

// ---- writing -----------------------------------------------------------------------------------

/// Shortest decimal text that reads back to the same value (std::to_chars round-trip guarantee).
/// "1e+08" becomes "1.0e+08": YAML 1.1 readers (PyYAML) take an exponent without a dot for a
/// string.
template <typename T>
std::string numberText(T value) {
  char buffer[64];
  const std::to_chars_result r = std::to_chars(buffer, buffer + sizeof(buffer), value);
  std::string s(buffer, r.ptr);
  const size_t e = s.find('e');
  if (e != std::string::npos && s.find('.') == std::string::npos) s.insert(e, ".0");
  return s;
}

class Writer {
 public:
  void operator()(const char* key, double value, const char* comment) {
    line(key, numberText(value), comment);
  }
  void operator()(const char* key, float value, const char* comment) {
    line(key, numberText(value), comment);
  }
  void operator()(const char* key, int value, const char* comment) {
    line(key, std::to_string(value), comment);
  }
  void operator()(const char* key, uint64_t value, const char* comment) {
    line(key, std::to_string(value), comment);
  }
  void operator()(const char* key, bool value, const char* comment) {
    line(key, value ? "true" : "false", comment);
  }
  void operator()(const char* key, frontend::HypothesisSource value, const char* comment) {
    line(key, frontend::hypothesisSourceName(value), comment);
  }
  void operator()(const char* key, frontend::Simd value, const char* comment) {
    line(key, frontend::simdName(value), comment);
  }
  /// A key that moved: nothing to write.
  void replaced(const char* /*old_key*/, const char* /*new_key*/) {}
  void operator()(const char* key, landmarks::Policy value, const char* comment) {
    line(key, landmarks::policyName(value), comment);
  }
  void operator()(const char* key, localization::Mode value, const char* comment) {
    line(key, localization::modeName(value), comment);
  }

  /// Old keys are not written.
  void moved(const char* /*old_key*/, const char* /*new_key*/, const char* /*why*/) {}

  template <typename F>
  void section(const char* key, const char* comment, F&& visit) {
    line(key, "", comment);
    indent_ += 2;
    visit(*this);
    indent_ -= 2;
  }

  [[nodiscard]] std::string text() const { return out_.str(); }

 private:
  /// Comments start in a fixed column so the values line up.
  static constexpr size_t kCommentColumn = 40;

  void line(const char* key, const std::string& value, const char* comment) {
    std::string s = std::string(indent_, ' ') + key + ":";
    if (!value.empty()) s += " " + value;
    s.resize(std::max(s.size() + 2, kCommentColumn), ' ');
    out_ << s << "# " << comment << "\n";
  }

  std::ostringstream out_;
  size_t indent_ = 0;
};

// ---- reading -----------------------------------------------------------------------------------

/// Thrown by the readers and turned into a Status by parseConfigYaml: parsing a file is an I/O
/// edge (STYLE §5), and threading a Status through ~80 key reads would bury the layout.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

[[noreturn]] void fail(const std::string& message) { throw ConfigError(message); }

std::string join(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}
std::string lineOf(const Node& n) { return " (line " + std::to_string(n.marks.line + 1) + ")"; }

/// How a node looks in an error message: a scalar's text in quotes, or the kind of node.
std::string describe(const Node& n) {
  if (n.isNullNode()) return "nothing";
  if (n.isSequence()) return "a sequence";
  if (n.isMap()) return "a map";
  return "\"" + n.as<std::string>() + "\"";
}

std::vector<std::string> words(const std::string& key) {
  std::vector<std::string> out;
  std::istringstream in(key);
  std::string w;
  while (std::getline(in, w, '_')) {
    if (!w.empty()) out.push_back(w);
  }
  return out;
}

/// The allowed keys an unknown key was probably meant to be: the nearest whole keys when within
/// a third of the letters, else the keys sharing a near-identical word ("treshold" ->
/// threshold_min, ...), else none.
std::vector<std::string> suggestions(const std::string& key,
                                     const std::vector<std::string>& allowed) {
  std::vector<std::string> out;
  size_t best = std::numeric_limits<size_t>::max();
  for (const std::string& a : allowed) best = std::min(best, editDistance(key, a));
  if (best <= std::max<size_t>(2, key.size() / 3)) {
    for (const std::string& a : allowed) {
      if (editDistance(key, a) == best) out.push_back(a);
    }
    return out;
  }
  for (const std::string& a : allowed) {
    bool near = false;
    for (const std::string& kw : words(key)) {
      if (kw.size() < 3) continue;
      for (const std::string& aw : words(a))
        near = near || editDistance(kw, aw) <= std::max<size_t>(1, kw.size() / 4);
    }
    if (near) out.push_back(a);
  }
  return out;
}

std::string listed(const std::vector<std::string>& names) {
  std::string s;
  for (size_t i = 0; i < names.size(); ++i) s += (i == 0 ? "" : ", ") + names[i];
  return s;
}

std::string scalarText(const Node& n, const std::string& path, const char* expected) {
  if (!n.isScalar()) fail(path + ": expected " + expected + ", got " + describe(n) + lineOf(n));
  return n.as<std::string>();
}

/// YAML's and C's spellings of infinity and NaN, which from_chars would accept or misreport.
bool isNonFiniteSpelling(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  if (!s.empty() && (s[0] == '+' || s[0] == '-')) s.erase(0, 1);
  return s == ".nan" || s == ".inf" || s == "nan" || s == "inf" || s == "infinity";
}

template <typename T>
T toFloating(const Node& n, const std::string& path) {
  const std::string s = scalarText(n, path, "a number");
  if (isNonFiniteSpelling(s))
    fail(path + ": must be a finite number, got \"" + s + "\"" + lineOf(n));
  const char* begin = s.data();
  const char* end = s.data() + s.size();
  if (begin != end && *begin == '+') ++begin;  // from_chars rejects a leading '+'
  T value{};
  const std::from_chars_result r = std::from_chars(begin, end, value);
  if (r.ec == std::errc::result_out_of_range) {
    fail(path + ": \"" + s + "\" is out of range for a " +
         (std::is_same_v<T, float> ? "32-bit float" : "double") + lineOf(n));
  }
  if (r.ec != std::errc() || r.ptr != end) {
    fail(path + ": expected a number, got \"" + s + "\"" + lineOf(n));
  }
  if (!std::isfinite(value))
    fail(path + ": must be a finite number, got \"" + s + "\"" + lineOf(n));
  return value;
}

template <typename T>
T toInteger(const Node& n, const std::string& path) {
  const char* expected = std::is_signed_v<T> ? "an integer" : "a non-negative integer";
  const std::string s = scalarText(n, path, expected);
  const char* begin = s.data();
  const char* end = s.data() + s.size();
  if (begin != end && *begin == '+') ++begin;
  T value{};
  const std::from_chars_result r = std::from_chars(begin, end, value, 10);
  if (r.ec == std::errc::result_out_of_range) {
    std::ostringstream range;
    range << "[" << +std::numeric_limits<T>::min() << ", " << +std::numeric_limits<T>::max() << "]";
    fail(path + ": " + s + " is out of range " + range.str() + lineOf(n));
  }
  if (r.ec != std::errc() || r.ptr != end) {
    fail(path + ": expected " + expected + ", got \"" + s + "\"" + lineOf(n));
  }
  return value;
}

bool toBool(const Node& n, const std::string& path) {
  const std::string s = scalarText(n, path, "true or false");
  for (const char* t : {"true", "True", "TRUE", "yes", "Yes", "YES", "on", "On", "ON"}) {
    if (s == t) return true;
  }
  for (const char* f : {"false", "False", "FALSE", "no", "No", "NO", "off", "Off", "OFF"}) {
    if (s == f) return false;
  }
  fail(path + ": expected true or false, got \"" + s + "\"" + lineOf(n));
}

/// Reads the keys of one map node into the visited fields; keys not visited are errors.
class Reader {
 public:
  /// node == nullptr: the section is absent, nothing to read.
  Reader(const Node* node, std::string path) : node_(node), path_(std::move(path)) {
    if (node_ != nullptr && !node_->isMap()) {
      fail((path_.empty() ? std::string("the document") : path_) +
           ": expected a map of 'key: value' entries, got " + describe(*node_) + lineOf(*node_));
    }
  }

  template <typename T>
  void operator()(const char* key, T& field, const char* /*comment*/) {
    allowed_.emplace_back(key);
    if (const Node* n = find(key)) read(*n, join(path_, key), &field);
  }

  template <typename F>
  void section(const char* key, const char* /*comment*/, F&& visit) {
    allowed_.emplace_back(key);
    Reader sub(find(key), join(path_, key));
    visit(sub);
    sub.rejectUnknownKeys();
  }

  /// A key that moved to `new_key` (a full path): an error naming the new key when present.
  void replaced(const char* old_key, const char* new_key) const {
    if (const Node* n = find(old_key)) {
      fail(join(path_, old_key) + " was replaced by " + new_key + lineOf(*n));
    }
  }

  /// A key of an earlier layout: reading it fails with where it went (new_key, relative to this
  /// map) or, for a removed key (new_key nullptr), why.
  void moved(const char* old_key, const char* new_key, const char* why) {
    const Node* n = find(old_key);
    if (n == nullptr) return;
    const std::string old_path = join(path_, old_key);
    if (new_key != nullptr) fail(old_path + " moved to " + join(path_, new_key) + lineOf(*n));
    fail(old_path + " was removed: " + why + lineOf(*n));
  }

  /// Call after visiting: fails on the first key (in key order) that no field claimed.
  void rejectUnknownKeys() const {
    if (node_ == nullptr) return;
    for (const auto& [key_node, value] : node_->asMap()) {
      (void)value;
      const std::string key = key_node.as<std::string>();
      if (std::find(allowed_.begin(), allowed_.end(), key) != allowed_.end()) continue;
      std::string message = "unknown key " + join(path_, key) + lineOf(key_node);
      const std::vector<std::string> hints = suggestions(key, allowed_);
      if (hints.size() == 1) {
        message += "; did you mean " + hints[0] + "?";
      } else if (!hints.empty()) {
        message += "; did you mean one of " + listed(hints) + "?";
      } else {
        message += "; allowed keys" + (path_.empty() ? std::string() : " in " + path_) + ": " +
                   listed(allowed_);
      }
      fail(message);
    }
  }

 private:
  [[nodiscard]] const Node* find(const char* key) const {
    if (node_ == nullptr) return nullptr;
    for (const auto& [key_node, value] : node_->asMap()) {
      if (key_node.isScalar() && key_node.as<std::string>() == key) return &value;
    }
    return nullptr;
  }

  static void read(const Node& n, const std::string& path, double* out) {
    *out = toFloating<double>(n, path);
  }
  static void read(const Node& n, const std::string& path, float* out) {
    *out = toFloating<float>(n, path);
  }
  static void read(const Node& n, const std::string& path, int* out) {
    *out = toInteger<int>(n, path);
  }
  static void read(const Node& n, const std::string& path, uint64_t* out) {
    *out = toInteger<uint64_t>(n, path);
  }
  static void read(const Node& n, const std::string& path, bool* out) { *out = toBool(n, path); }
  static void read(const Node& n, const std::string& path, frontend::HypothesisSource* out) {
    readEnum(n, path, out, frontend::parseHypothesisSource);
  }
  static void read(const Node& n, const std::string& path, frontend::Simd* out) {
    readEnum(n, path, out, frontend::parseSimd);
  }
  static void read(const Node& n, const std::string& path, landmarks::Policy* out) {
    readEnum(n, path, out, landmarks::parsePolicy);
  }
  static void read(const Node& n, const std::string& path, localization::Mode* out) {
    readEnum(n, path, out, localization::parseMode);
  }
  template <typename E>
  static void readEnum(const Node& n,
                       const std::string& path,
                       E* out,
                       Status (*parse)(const std::string&, E*)) {
    const std::string s = scalarText(n, path, "a name");
    if (Status st = parse(s, out); !st) fail(path + ": " + st.message() + lineOf(n));
  }

  const Node* node_;
  std::string path_;
  std::vector<std::string> allowed_;
};

// ---- YAML syntax errors ------------------------------------------------------------------------

}  // namespace

Status PipelineConfig::validate() const {
  if (Status s = frontend.validate(); !s) return s;   // already "frontend.<group>.<key> = ..."
  if (Status s = landmarks.validate(); !s) return s;  // already "landmarks.<group>.<key> = ..."
  if (Status s = mapping.validate(); !s) {
    if (s.message().rfind("mapping.", 0) == 0) return s;
    return Status::error("mapping: " + s.message());
  }
  return localization.validate();  // already "localization.<group>.<key> = ..."
}

Status parseConfigYaml(const std::string& yaml_text, PipelineConfig* config) {
  if (config == nullptr) return Status::error("parseConfigYaml: null config");
  Yaml doc;
  if (const auto error = parseYaml(yaml_text, &doc))
    return Status::error("YAML syntax error: " + *error);
  PipelineConfig parsed = *config;
  try {
    const Node& root = doc.node();
    // An empty document (or one holding only comments) overrides nothing.
    Reader reader(root.isNullNode() ? nullptr : &root, "");
    config_schema::visitConfig(parsed, reader);
    reader.rejectUnknownKeys();
  } catch (const ConfigError& e) {
    return Status::error(e.what());
  } catch (const std::exception& e) {
    // MRPT accessors throw on node kinds the readers did not expect.
    return Status::error("cannot read config: " + mrptMessage(e));
  }
  if (Status s = parsed.validate(); !s) return s;
  *config = parsed;
  return Status::ok();
}

Status loadConfigFile(const std::string& path, PipelineConfig* config) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path file(path);
  if (!fs::exists(file, ec)) return Status::error(path + ": cannot read config file: no such file");
  if (fs::is_directory(file, ec))
    return Status::error(path + ": cannot read config file: it is a directory");
  std::ifstream in(file, std::ios::binary);
  if (!in) return Status::error(path + ": cannot read config file: " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return Status::error(path + ": cannot read config file: read error");
  const Status s = parseConfigYaml(text.str(), config);
  if (!s) return Status::error(path + ": " + s.message());
  return Status::ok();
}

std::string toYaml(const PipelineConfig& config) {
  Writer writer;
  config_schema::visitConfig(config, writer);
  return "# TwoCam pipeline configuration (twocam run --config FILE); layout and errors: "
         "docs/config.md.\n"
         "# Every key is optional: absent keys keep their defaults. Unknown keys are errors.\n"
         "# Units in brackets; [-] is dimensionless.\n" +
         writer.text();
}

}  // namespace twocam::pipeline
