#pragma once
/// Parsing YAML text with MRPT 2.5 (mrpt::containers::yaml) so that errors read well: syntax
/// errors with line and column, MRPT exceptions cut to their message, and "did you mean" help
/// for unknown keys. The schemas (which keys exist, their types) stay with their readers:
/// sim/world_io.cpp for world files, pipeline/config.cpp for the run config.

#include <mrpt/containers/yaml.h>

#include <cstddef>
#include <exception>
#include <optional>
#include <string>

namespace twocam::yaml {

/// Checks what the parser may see: well-formed UTF-8 (RFC 3629), no control characters other
/// than tab, line feed and carriage return, no YAML directive lines ("%YAML", "%TAG"; TwoCam's
/// files need none). Returns nullopt when fine, else "line L, column C: <reason>".
/// This is the guard that makes parseYaml terminate: libfyaml's scanners advance by decoded
/// UTF-8 characters and spin on a byte they cannot decode (fuzzing found 15 such inputs, all
/// a directive followed by invalid UTF-8), so no such byte and no directive reaches them.
std::optional<std::string> checkYamlText(const std::string& text);

/// The first key given twice in one map, as "line L: duplicate key 'k' (first at line F)";
/// nullopt if none. MRPT keeps one of the values silently. Covers block maps (also as sequence
/// items) and flow maps; block scalars are skipped. Run by parseYaml after a successful parse.
std::optional<std::string> findDuplicateKey(const std::string& text);

/// Parses `text` into *doc (after checkYamlText; duplicate keys are errors). Returns nullopt on
/// success, else the reason, e.g. "line 2, column 1: flow sequence without a closing bracket".
///
/// MRPT 2.5 hands libfyaml's syntax errors to C's stderr and returns the tree parsed up to the
/// error as if nothing happened; stderr is redirected for the duration of the parse to learn
/// about it. The swap is process-wide: another thread printing with C stdio meanwhile would be
/// captured too (std::cerr is not affected), so parse YAML before starting threads.
std::optional<std::string> parseYaml(const std::string& text, mrpt::containers::yaml* doc);

/// The "Message:" line of an MRPT exception (its what() also holds a call stack); MRPT's
/// wording for "key:" with nothing after it is replaced by a plain explanation.
std::string mrptMessage(const std::exception& e);

/// Levenshtein distance between two keys, for "did you mean" hints.
size_t editDistance(const std::string& a, const std::string& b);

}  // namespace twocam::yaml
