// A reader for the YAML that settings and sensor files are written in (ORB-SLAM2's settings,
// OpenCV FileStorage's "%YAML:1.0" files, EuRoC's sensor.yaml), written here so that a malformed
// file gets a message with its line instead of a third-party parser's hang or exception (OpenCV
// 4.6's parser never returned on some 11-byte files; see docs/RELIABILITY.md).
//
// The subset: block mappings and block lists by indentation (spaces), flow lists `[a, b]` and
// flow maps `{a: 1}` (they may span lines), plain, 'single' and "double" quoted scalars, comments,
// tags such as `!!opencv-matrix` (kept, not interpreted), directives (`%YAML:1.0`), `---` and
// `...` around one document. Not supported, each refused with its line: block scalars (| and >),
// anchors and aliases, complex keys (?), multi-line scalars, a second document, tabs in the
// indentation. Plain scalars are typed as YAML's core schema does: null (empty, ~, null), integer
// (32 bits: a longer integer is refused rather than wrapped), real (with .inf and .nan), else text.
// Nesting is limited to kMaxYamlDepth levels and the file to kMaxYamlBytes, so that no input can
// exhaust the stack or the memory. Private to porta_dataset.
#pragma once

#include <cstddef>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace porta::slam::detail {

/// A malformed document; what() is "line N: problem".
class YamlError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

inline constexpr int kMaxYamlDepth = 64;
inline constexpr std::size_t kMaxYamlBytes = std::size_t{1} << 20;  // settings files are a few KB

struct YamlEntry;

struct YamlNode {
  enum class Kind { null, integer, real, text, list, map };

  Kind kind = Kind::null;
  int line = 0;         ///< where the node starts (1-based)
  std::string tag;      ///< "" or the tag as written, e.g. "!!opencv-matrix"
  std::string text;     ///< scalars: the value as written (quotes removed, escapes resolved)
  double number = 0.0;  ///< integer and real: the value
  std::vector<YamlNode> items;                             ///< list
  std::vector<YamlEntry> entries;  ///< map, in file order (keys unique)

  bool is_number() const { return kind == Kind::integer || kind == Kind::real; }
  bool is_null() const { return kind == Kind::null; }
  /// The entry of a map with this key; nullptr when absent or when this is not a map.
  const YamlNode* find(std::string_view key) const;
  /// For messages: "the text 'fast'", "a number", "a list", "a map", "an empty value".
  std::string describe() const;
};

struct YamlEntry {
  std::string key;
  YamlNode value;
};

/// Parses one document; its root is a map, a list or (for a document of only comments) null.
/// Throws YamlError naming the line of the first problem.
YamlNode parse_yaml(std::string_view content);

/// Reads and parses a file whose root must be a map of keys. Returns an error text without the
/// file's name ("no such file", "the file is empty", "not valid YAML: line 3: ...") on failure.
std::optional<std::string> read_yaml_file(const std::filesystem::path& path, YamlNode& root);

}  // namespace porta::slam::detail
