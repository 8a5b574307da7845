#include "yaml/yaml_text.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <vector>

namespace twocam::yaml {
namespace {

/// Redirects C's stderr into memory while alive (glibc's open_memstream).
class StderrCapture {
 public:
  StderrCapture() {
#if defined(__GLIBC__)
    stream_ = open_memstream(&buffer_, &size_);
    if (stream_ != nullptr) {
      saved_ = stderr;
      stderr = stream_;
    }
#endif
  }
  ~StderrCapture() { text(); }
  StderrCapture(const StderrCapture&) = delete;
  StderrCapture& operator=(const StderrCapture&) = delete;

  /// Restores stderr (once) and returns what was written meanwhile.
  std::string text() {
#if defined(__GLIBC__)
    if (stream_ != nullptr) {
      stderr = saved_;
      std::fclose(stream_);
      stream_ = nullptr;
      captured_.assign(buffer_, size_);
      std::free(buffer_);
      buffer_ = nullptr;
    }
#endif
    return captured_;
  }

 private:
  std::FILE* stream_ = nullptr;
  std::FILE* saved_ = nullptr;
  char* buffer_ = nullptr;
  size_t size_ = 0;
  std::string captured_;
};

/// Turns libfyaml's "<memory-@0x...>:2:1: error: flow sequence without a closing bracket"
/// into "line 2, column 1: flow sequence without a closing bracket"; empty if no error.
std::string syntaxError(const std::string& diagnostics) {
  std::istringstream lines(diagnostics);
  std::string line;
  while (std::getline(lines, line)) {
    const size_t at = line.find(": error: ");
    if (at == std::string::npos) continue;
    const std::string what = line.substr(at + std::strlen(": error: "));
    // The location ends in ":<line>:<column>".
    const std::string where = line.substr(0, at);
    const size_t c = where.rfind(':');
    const size_t l = c == std::string::npos || c == 0 ? std::string::npos : where.rfind(':', c - 1);
    if (l == std::string::npos) return what;
    return "line " + where.substr(l + 1, c - l - 1) + ", column " + where.substr(c + 1) + ": " +
           what;
  }
  return {};
}

/// "line L, column C: " for the byte at `at` of `text` (columns count bytes, from 1).
std::string position(const std::string& text, size_t at) {
  size_t line = 1;
  size_t line_start = 0;
  for (size_t i = 0; i < at; ++i) {
    if (text[i] == '\n') {
      ++line;
      line_start = i + 1;
    }
  }
  return "line " + std::to_string(line) + ", column " + std::to_string(at - line_start + 1) + ": ";
}

std::string hexByte(unsigned char c) {
  char buf[8];
  std::snprintf(buf, sizeof(buf), "0x%02x", static_cast<unsigned>(c));
  return buf;
}

/// Length of the well-formed UTF-8 sequence at text[at] (RFC 3629: no overlong forms, no
/// surrogates, nothing above U+10FFFF), or 0 if it is not one.
size_t utf8Length(const std::string& text, size_t at) {
  const auto byte = [&](size_t i) { return static_cast<unsigned char>(text[i]); };
  const unsigned char c = byte(at);
  if (c < 0x80) return 1;
  size_t n = 0;
  unsigned char lo = 0x80;
  unsigned char hi = 0xbf;
  if (c >= 0xc2 && c <= 0xdf) {
    n = 2;
  } else if (c >= 0xe0 && c <= 0xef) {
    n = 3;
    if (c == 0xe0) lo = 0xa0;
    if (c == 0xed) hi = 0x9f;
  } else if (c >= 0xf0 && c <= 0xf4) {
    n = 4;
    if (c == 0xf0) lo = 0x90;
    if (c == 0xf4) hi = 0x8f;
  } else {
    return 0;
  }
  if (at + n > text.size()) return 0;
  if (byte(at + 1) < lo || byte(at + 1) > hi) return 0;
  for (size_t i = 2; i < n; ++i) {
    if (byte(at + i) < 0x80 || byte(at + i) > 0xbf) return 0;
  }
  return n;
}

// ---- duplicate keys ------------------------------------------------------------------------
// MRPT 2.5 keeps one value of a key given twice in a map, silently. The scan below finds
// duplicates in what TwoCam's files use: block maps (nested, in sequences) and flow maps
// ({a: 1, b: 2}) on one or more lines. Block scalars (| and >) are skipped.

struct FlowScan {
  const std::string& text;
  size_t i = 0;
  std::optional<std::string> error;
  /// 1-based line of text[at], for flow text that starts on line `first_line`.
  size_t first_line;
  size_t lineAt(size_t at) const {
    return first_line + static_cast<size_t>(std::count(text.begin(), text.begin() + at, '\n'));
  }
  void skipSpace() {
    while (i < text.size() &&
           (text[i] == ' ' || text[i] == '\t' || text[i] == '\n' || text[i] == '\r')) {
      ++i;
    }
  }
  /// A scalar up to one of `stops` at this level (quotes honoured); returns it trimmed.
  std::string scalar(const char* stops) {
    std::string out;
    while (i < text.size() && std::strchr(stops, text[i]) == nullptr) {
      if (text[i] == '\'' || text[i] == '"') {
        const char q = text[i];
        out += text[i++];
        while (i < text.size() && text[i] != q) out += text[i++];
        if (i < text.size()) out += text[i++];
        continue;
      }
      // ':' ends a key only before a space or a flow indicator.
      if (text[i] == ':' && std::strchr(stops, ':') != nullptr) break;
      out += text[i++];
    }
    while (!out.empty() && std::isspace(static_cast<unsigned char>(out.back()))) out.pop_back();
    return out;
  }
  /// Nesting of the collection being scanned; deeper ones are left alone (MRPT parsed them).
  int depth = 0;
  static constexpr int kMaxDepth = 64;
  void value() {
    skipSpace();
    if (i >= text.size()) return;
    if ((text[i] == '{' || text[i] == '[') && depth >= kMaxDepth) {
      i = text.size();
      return;
    }
    if (text[i] == '{') {
      map();
    } else if (text[i] == '[') {
      sequence();
    } else {
      scalar(",}]");
    }
  }
  void map() {
    ++i;  // '{'
    ++depth;
    struct Leave {
      int& d;
      ~Leave() { --d; }
    } leave{depth};
    std::vector<std::string> keys;
    while (!error) {
      skipSpace();
      if (i >= text.size()) return;
      if (text[i] == '}') {
        ++i;
        return;
      }
      if (text[i] == ',' || text[i] == ']') {  // a stray ']' is the parser's to report
        ++i;
        continue;
      }
      const size_t at = i;
      std::string key = scalar(":,}");
      if (std::find(keys.begin(), keys.end(), key) != keys.end() && !key.empty()) {
        error = "line " + std::to_string(lineAt(at)) + ": duplicate key '" + key + "'";
        return;
      }
      keys.push_back(key);
      if (i < text.size() && text[i] == ':') {
        ++i;
        value();
      }
      if (i == at) ++i;  // always make progress
    }
  }
  void sequence() {
    ++i;  // '['
    ++depth;
    struct Leave {
      int& d;
      ~Leave() { --d; }
    } leave{depth};
    while (!error) {
      skipSpace();
      if (i >= text.size()) return;
      if (text[i] == ']') {
        ++i;
        return;
      }
      if (text[i] == ',' || text[i] == '}') {  // a stray '}' is the parser's to report
        ++i;
        continue;
      }
      const size_t before = i;
      value();
      if (i == before) ++i;  // always make progress
    }
  }
};

/// Strips a comment (a '#' at the start or after a space, outside quotes).
std::string withoutComment(const std::string& line) {
  char quote = 0;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quote != 0) {
      if (c == quote) quote = 0;
    } else if (c == '\'' || c == '"') {
      quote = c;
    } else if (c == '#' && (i == 0 || line[i - 1] == ' ' || line[i - 1] == '\t')) {
      return line.substr(0, i);
    }
  }
  return line;
}

/// Brackets opened minus closed outside quotes.
int bracketBalance(const std::string& s) {
  int depth = 0;
  char quote = 0;
  for (char c : s) {
    if (quote != 0) {
      if (c == quote) quote = 0;
    } else if (c == '\'' || c == '"') {
      quote = c;
    } else if (c == '{' || c == '[') {
      ++depth;
    } else if (c == '}' || c == ']') {
      --depth;
    }
  }
  return depth;
}

}  // namespace

std::optional<std::string> findDuplicateKey(const std::string& text) {
  std::vector<std::string> lines;
  {
    std::istringstream in(text);
    std::string l;
    while (std::getline(in, l)) {
      if (!l.empty() && l.back() == '\r') l.pop_back();
      lines.push_back(withoutComment(l));
    }
  }
  struct Level {
    size_t indent;
    std::vector<std::pair<std::string, size_t>> keys;  // key, line
  };
  std::vector<Level> levels;
  std::optional<size_t> block_scalar_indent;
  for (size_t n = 0; n < lines.size(); ++n) {
    const std::string& line = lines[n];
    const size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos) continue;
    size_t col = line.find_first_not_of(' ');
    if (block_scalar_indent) {
      if (col > *block_scalar_indent) continue;
      block_scalar_indent.reset();
    }
    if (line.compare(col, 3, "---") == 0 || line.compare(col, 3, "...") == 0) {
      levels.clear();
      continue;
    }
    bool new_item = false;
    while (col < line.size() && line[col] == '-' &&
           (col + 1 == line.size() || line[col + 1] == ' ')) {
      new_item = true;
      col = line.find_first_not_of(' ', col + 1);
      if (col == std::string::npos) break;
    }
    if (col == std::string::npos) continue;
    std::string rest = line.substr(col);
    // A flow collection (possibly over several lines): scanned as one piece.
    const auto scan_flow = [&](std::string flow, size_t start_line) -> std::optional<std::string> {
      size_t last = n;
      while (bracketBalance(flow) > 0 && last + 1 < lines.size()) flow += "\n" + lines[++last];
      n = last;
      FlowScan scan{flow, 0, std::nullopt, start_line};
      scan.value();
      return scan.error;
    };
    if (rest[0] == '{' || rest[0] == '[') {
      if (auto e = scan_flow(rest, n + 1)) return e;
      continue;
    }
    // "key: value" or "key:" (quoted keys allowed).
    size_t colon = std::string::npos;
    char quote = 0;
    for (size_t i = 0; i < rest.size(); ++i) {
      const char c = rest[i];
      if (quote != 0) {
        if (c == quote) quote = 0;
      } else if ((c == '\'' || c == '"') && i == 0) {
        quote = c;
      } else if (c == ':' && (i + 1 == rest.size() || rest[i + 1] == ' ' || rest[i + 1] == '\t')) {
        colon = i;
        break;
      }
    }
    if (colon == std::string::npos) continue;  // a plain scalar (sequence item, continuation)
    std::string key = rest.substr(0, colon);
    while (!key.empty() && std::isspace(static_cast<unsigned char>(key.back()))) key.pop_back();
    if (new_item) {
      while (!levels.empty() && levels.back().indent >= col) levels.pop_back();
      levels.push_back({col, {}});
    } else {
      while (!levels.empty() && levels.back().indent > col) levels.pop_back();
      if (levels.empty() || levels.back().indent != col) levels.push_back({col, {}});
    }
    for (const auto& [k, at] : levels.back().keys) {
      if (k == key) {
        return "line " + std::to_string(n + 1) + ": duplicate key '" + key + "' (first at line " +
               std::to_string(at) + ")";
      }
    }
    levels.back().keys.emplace_back(key, n + 1);
    std::string value = rest.substr(colon + 1);
    const size_t v = value.find_first_not_of(" \t");
    if (v == std::string::npos) continue;
    value = value.substr(v);
    if (value[0] == '|' || value[0] == '>') {
      block_scalar_indent = col;
    } else if (value[0] == '{' || value[0] == '[') {
      if (auto e = scan_flow(value, n + 1)) return e;
    }
  }
  return std::nullopt;
}

/// Deepest flow nesting passed to the parser: MRPT builds and frees its tree recursively, and
/// fuzzing found thousands of nested brackets taking over 10 s (TwoCam's files nest 3 deep).
constexpr int kMaxFlowDepth = 64;

std::optional<std::string> checkYamlText(const std::string& text) {
  bool line_start = true;
  int depth = 0;  // flow brackets open (quotes not honoured: a bound, not a parse)
  for (size_t i = 0; i < text.size();) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c == '[' || c == '{') {
      if (++depth > kMaxFlowDepth) {
        return position(text, i) + "collections nested deeper than " +
               std::to_string(kMaxFlowDepth) + " levels";
      }
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
    if (line_start && c == '%') {
      return position(text, i) + "YAML directives ('%...') are not supported; remove the line";
    }
    if (c < 0x20 && c != '\t' && c != '\n' && c != '\r') {
      return position(text, i) + "control character " + hexByte(c) +
             " (only tab, line feed and carriage return are allowed)";
    }
    if (c == 0x7f) return position(text, i) + "control character 0x7f";
    const size_t n = utf8Length(text, i);
    if (n == 0) {
      return position(text, i) + "byte " + hexByte(c) +
             " is not valid UTF-8 (the file must be UTF-8 text)";
    }
    // A byte order mark at the start of the file does not end the line start.
    const bool bom = i == 0 && n == 3 && text.compare(0, 3, "\xef\xbb\xbf") == 0;
    line_start = c == '\n' || (bom && line_start);
    i += n;
  }
  return std::nullopt;
}

std::string mrptMessage(const std::exception& e) {
  std::string s = e.what();
  // MRPT 2.5's wording for "key:" with nothing after it (e.g. a section whose keys are all
  // commented out), which carries no position.
  if (s.find("empty scalar") != std::string::npos) {
    return "a key has no value; write a value, or remove the key (or the section, if all its keys "
           "are "
           "commented out)";
  }
  const size_t at = s.find("Message:");
  if (at != std::string::npos) s = s.substr(at + std::strlen("Message:"));
  s = s.substr(0, s.find('\n'));
  const size_t first = s.find_first_not_of(" \t");
  return first == std::string::npos ? std::string("unknown error") : s.substr(first);
}

std::optional<std::string> parseYaml(const std::string& text, mrpt::containers::yaml* doc) {
  // libfyaml (under MRPT 2.5) loops forever on some invalid UTF-8 (e.g. the two bytes "%\xff":
  // its directive scanner does not advance past a byte its decoder rejects). Only text that
  // passed the check reaches it.
  if (auto bad = checkYamlText(text)) return bad;
  std::string exception_message;
  StderrCapture capture;
  try {
    *doc = mrpt::containers::yaml::FromText(text);
  } catch (const std::exception& e) {
    exception_message = mrptMessage(e);
  }
  const std::string syntax = syntaxError(capture.text());
  // The syntax error is the cause; MRPT's exception, if any, is a consequence of it.
  if (!syntax.empty()) return syntax;
  if (!exception_message.empty()) return exception_message;
  return findDuplicateKey(text);
}

size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t substitute = diagonal + (a[i - 1] == b[j - 1] ? 0 : 1);
      diagonal = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, substitute});
    }
  }
  return row[b.size()];
}

}  // namespace twocam::yaml
