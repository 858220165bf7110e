#include "yaml_reader.hpp"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <system_error>

namespace porta::slam::detail {

namespace {

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r'; }
bool is_digit(char c) { return c >= '0' && c <= '9'; }

/// The line's text for a message, cut at 40 characters.
std::string excerpt(std::string_view text) {
  const std::size_t end = std::min(text.find('\n'), text.size());
  std::string shown(text.substr(0, std::min<std::size_t>(end, 40)));
  while (!shown.empty() && is_blank(shown.back())) shown.pop_back();
  return end > 40 ? shown + "..." : shown;
}

// ---- Scalars ----------------------------------------------------------------------------------

bool matches_integer(std::string_view s) {
  std::size_t i = s.size() > 0 && (s[0] == '-' || s[0] == '+') ? 1 : 0;
  if (i == s.size()) return false;
  for (; i < s.size(); ++i)
    if (!is_digit(s[i])) return false;
  return true;
}

/// [-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)([eE][-+]?[0-9]+)?; `negative_exponent` / `zero_integer_part`
/// say which way a value beyond double's range went.
bool matches_real(std::string_view s, bool& negative_exponent, bool& zero_integer_part) {
  std::size_t i = s.size() > 0 && (s[0] == '-' || s[0] == '+') ? 1 : 0;
  std::size_t integer_digits = 0, fraction_digits = 0;
  zero_integer_part = true;
  for (; i < s.size() && is_digit(s[i]); ++i, ++integer_digits)
    if (s[i] != '0') zero_integer_part = false;
  if (i < s.size() && s[i] == '.')
    for (++i; i < s.size() && is_digit(s[i]); ++i) ++fraction_digits;
  if (integer_digits + fraction_digits == 0) return false;
  negative_exponent = false;
  if (i < s.size() && (s[i] == 'e' || s[i] == 'E')) {
    ++i;
    if (i < s.size() && (s[i] == '-' || s[i] == '+')) negative_exponent = s[i++] == '-';
    std::size_t exponent_digits = 0;
    for (; i < s.size() && is_digit(s[i]); ++i) ++exponent_digits;
    if (exponent_digits == 0) return false;
  }
  return i == s.size();
}

/// Types a plain (unquoted) scalar as YAML's core schema does.
void type_plain_scalar(YamlNode& node) {
  const std::string& s = node.text;
  if (s.empty() || s == "~" || s == "null" || s == "Null" || s == "NULL") {
    node.kind = YamlNode::Kind::null;
    return;
  }
  const bool negative = s[0] == '-';
  const std::string_view unsigned_text = std::string_view(s).substr(s[0] == '-' || s[0] == '+' ? 1 : 0);
  if (matches_integer(s)) {
    std::int64_t value = 0;
    const auto [end, error] = std::from_chars(unsigned_text.data(), unsigned_text.data() + unsigned_text.size(), value);
    const std::int64_t limit = negative ? -std::int64_t{std::numeric_limits<std::int32_t>::min()}
                                        : std::int64_t{std::numeric_limits<std::int32_t>::max()};
    if (error != std::errc() || end != unsigned_text.data() + unsigned_text.size() || value > limit)
      throw YamlError("line " + std::to_string(node.line) + ": the integer " + s + " is out of range (beyond 32 bits)");
    node.kind = YamlNode::Kind::integer;
    node.number = static_cast<double>(negative ? -value : value);
    return;
  }
  bool negative_exponent = false, zero_integer_part = false;
  if (matches_real(s, negative_exponent, zero_integer_part)) {
    double value = 0.0;
    const auto [end, error] = std::from_chars(unsigned_text.data(), unsigned_text.data() + unsigned_text.size(), value);
    if (error == std::errc::result_out_of_range) {
      const bool underflow = negative_exponent || (zero_integer_part && s.find_first_of("eE") == std::string::npos);
      value = underflow ? 0.0 : std::numeric_limits<double>::infinity();
    }
    node.kind = YamlNode::Kind::real;
    node.number = negative ? -value : value;
    return;
  }
  const std::string_view special = unsigned_text;
  if (special == ".inf" || special == ".Inf" || special == ".INF") {
    node.kind = YamlNode::Kind::real;
    node.number = negative ? -std::numeric_limits<double>::infinity() : std::numeric_limits<double>::infinity();
    return;
  }
  if (s == ".nan" || s == ".NaN" || s == ".NAN") {
    node.kind = YamlNode::Kind::real;
    node.number = std::numeric_limits<double>::quiet_NaN();
    return;
  }
  node.kind = YamlNode::Kind::text;
}

// ---- The parser --------------------------------------------------------------------------------

class Parser {
 public:
  explicit Parser(std::string_view text) : s_(text) {}

  YamlNode document() {
    check_characters();
    bool started = false;
    while (const auto c = peek()) {
      if (c->column == 0 && s_[c->at] == '%' && !started) {  // a directive: %YAML:1.0, %TAG ...
        skip_to_line_end(c->at);
        continue;
      }
      if (is_marker(*c, "---")) {
        started = true;
        advance_to(c->at + 3);
        end_of_line("after '---' (content on the marker's line is not supported)");
        continue;
      }
      break;
    }
    const auto first = peek();
    YamlNode root = block_node(0, 0);
    if (const auto c = peek()) {
      if (is_marker(*c, "...")) {
        advance_to(c->at + 3);
        end_of_line("after '...'");
        if (const auto more = peek()) fail(more->line, "content after the end of the document ('...')");
      } else if (is_marker(*c, "---")) {
        fail(c->line, "a second document ('---') is not supported");
      } else if (first && c->column < first->column) {
        fail(c->line, "is indented less than the first key (line " + std::to_string(first->line) + ")");
      } else {
        fail(c->line, "unexpected '" + excerpt(s_.substr(c->at)) + "'");
      }
    }
    return root;
  }

 private:
  struct Content {
    std::size_t at;  ///< first byte of the content
    int column;      ///< its column on its line (0-based)
    int line;
  };

  [[noreturn]] static void fail(int line, const std::string& problem) {
    throw YamlError("line " + std::to_string(line) + ": " + problem);
  }

  void check_characters() const {
    int line = 1;
    for (const char c : s_) {
      if (c == '\n') ++line;
      const auto u = static_cast<unsigned char>(c);
      if (u < 0x20 && c != '\n' && c != '\t' && c != '\r') {
        char code[8];
        std::snprintf(code, sizeof code, "0x%02x", u);
        fail(line, std::string("a control character (") + code + ") is not allowed in a YAML file");
      }
    }
  }

  bool at_end(std::size_t i) const { return i >= s_.size(); }
  char at(std::size_t i) const { return i < s_.size() ? s_[i] : '\0'; }
  bool ends_token(std::size_t i) const { return at_end(i) || is_blank(s_[i]) || s_[i] == '\n'; }

  void advance_to(std::size_t i) {
    for (; pos_ < i && pos_ < s_.size(); ++pos_) {
      if (s_[pos_] == '\n') {
        ++line_;
        line_start_ = pos_ + 1;
      }
    }
  }
  void skip_to_line_end(std::size_t from) {
    std::size_t end = from;
    while (!at_end(end) && s_[end] != '\n') ++end;
    advance_to(end);
  }

  /// The next content (not blank, not a comment) from pos_, without moving; nullopt at the end.
  std::optional<Content> peek() const {
    std::size_t p = pos_, line_start = line_start_;
    int line = line_;
    bool in_indentation = p == line_start;
    while (p < s_.size()) {
      const char c = s_[p];
      if (c == '\n') {
        ++line;
        line_start = ++p;
        in_indentation = true;
      } else if (c == ' ' || c == '\r') {
        ++p;
      } else if (c == '\t') {
        if (in_indentation) fail(line, "a tab in the indentation (YAML indents with spaces)");
        ++p;
      } else if (c == '#') {
        while (p < s_.size() && s_[p] != '\n') ++p;
      } else {
        return Content{p, static_cast<int>(p - line_start), line};
      }
    }
    return std::nullopt;
  }

  bool is_marker(const Content& c, const char* marker) const {
    return c.column == 0 && s_.compare(c.at, 3, marker) == 0 && ends_token(c.at + 3);
  }
  bool is_list_entry(std::size_t at) const { return at < s_.size() && s_[at] == '-' && ends_token(at + 1); }

  void skip_blanks() {
    std::size_t p = pos_;
    while (!at_end(p) && is_blank(s_[p])) ++p;
    advance_to(p);
  }
  /// Nothing but blanks and a comment may follow on this line; moves past its end.
  void end_of_line(const char* where) {
    skip_blanks();
    if (at_end(pos_)) return;
    if (s_[pos_] == '#' || s_[pos_] == '\n') {
      skip_to_line_end(pos_);
      advance_to(pos_ + 1);
      return;
    }
    fail(line_, std::string("unexpected '") + excerpt(s_.substr(pos_)) + "' " + where);
  }
  bool rest_of_line_is_empty() const {
    std::size_t p = pos_;
    while (!at_end(p) && is_blank(s_[p])) ++p;
    return at_end(p) || s_[p] == '\n' || s_[p] == '#';
  }

  /// An empty list or map starting here, `depth` levels deep (bounded).
  YamlNode start_collection(YamlNode::Kind kind, int depth) const {
    if (depth > kMaxYamlDepth) fail(line_, "nested more than " + std::to_string(kMaxYamlDepth) + " levels deep");
    YamlNode node;
    node.kind = kind;
    node.line = line_;
    return node;
  }
  bool is_document_marker(const Content& c) const { return is_marker(c, "---") || is_marker(c, "..."); }

  // -- Block structure --

  /// A block map or list starting at the next content line, when that is at `min_column` or
  /// deeper; a null node otherwise.
  YamlNode block_node(int min_column, int depth) {
    const auto c = peek();
    YamlNode null;
    null.line = c ? c->line : line_;
    if (!c || c->column < min_column || is_document_marker(*c)) return null;
    advance_to(c->at);
    if (is_list_entry(c->at)) return block_list(c->column, depth + 1);
    return block_map(c->column, depth + 1);
  }

  YamlNode block_list(int column, int depth) {
    YamlNode node = start_collection(YamlNode::Kind::list, depth);
    while (const auto c = peek()) {
      if (c->column < column || !is_list_entry(c->at)) break;
      if (c->column > column) fail(c->line, "is indented more than the list entries above it");
      advance_to(c->at + 1);
      node.items.push_back(entry_value(column, depth, /*in_list=*/true));
    }
    if (const auto c = peek(); c && c->column > column && !is_document_marker(*c))
      fail(c->line, "is indented more than the list entries above it");
    return node;
  }

  YamlNode block_map(int column, int depth) {
    YamlNode node = start_collection(YamlNode::Kind::map, depth);
    while (const auto c = peek()) {
      if (c->column < column || is_document_marker(*c)) break;
      if (c->column > column) fail(c->line, "is indented more than the key above it");
      if (is_list_entry(c->at)) fail(c->line, "a list entry ('- ') where a key was expected");
      advance_to(c->at);
      const int key_line = line_;
      std::string key = block_key();
      for (const auto& [existing, value] : node.entries) {
        if (existing == key)
          fail(key_line, "the key '" + key + "' appears twice (first on line " + std::to_string(value.line) + ")");
      }
      YamlNode value = entry_value(column, depth, /*in_list=*/false);
      if (value.is_null() && value.tag.empty()) value.line = key_line;
      node.entries.push_back(YamlEntry{std::move(key), std::move(value)});
    }
    return node;
  }

  /// Where the plain key of a "key: value" line at `from` ends (the ':'), or npos.
  std::size_t plain_key_colon(std::size_t from) const {
    for (std::size_t p = from; !at_end(p) && s_[p] != '\n'; ++p) {
      if (s_[p] == '#' && p > from && is_blank(s_[p - 1])) return std::string_view::npos;
      if (s_[p] == ':' && ends_token(p + 1)) return p;
    }
    return std::string_view::npos;
  }
  bool starts_map_entry(std::size_t at) const {
    const char c = this->at(at);
    if (c == '"' || c == '\'') {
      std::size_t p = at + 1;
      while (!at_end(p) && s_[p] != '\n' && s_[p] != c) p += s_[p] == '\\' && c == '"' ? 2 : 1;
      if (at_end(p) || s_[p] != c) return false;
      for (++p; !at_end(p) && is_blank(s_[p]);) ++p;
      return this->at(p) == ':' && ends_token(p + 1);
    }
    if (c == '[' || c == '{') return false;
    return plain_key_colon(at) != std::string_view::npos;
  }

  std::string block_key() {
    const char c = at(pos_);
    if (c == '"' || c == '\'') {
      const YamlNode key = quoted_scalar();
      skip_blanks();
      if (at(pos_) != ':' || !ends_token(pos_ + 1)) fail(line_, "expected ':' after the quoted key");
      advance_to(pos_ + 1);
      return key.text;
    }
    if (c == '?') fail(line_, "complex keys ('? ') are not supported");
    if (std::strchr("[{&*!|>%@`", c) != nullptr)
      fail(line_, std::string("a key cannot start with '") + c + "' here ('" + excerpt(s_.substr(pos_)) + "')");
    const std::size_t colon = plain_key_colon(pos_);
    if (colon == std::string_view::npos)
      fail(line_, "expected 'key: value', found '" + excerpt(s_.substr(pos_)) + "'");
    std::string key(s_.substr(pos_, colon - pos_));
    while (!key.empty() && is_blank(key.back())) key.pop_back();
    if (key.empty()) fail(line_, "a key is empty");
    advance_to(colon + 1);
    return key;
  }

  /// The value after "key:" (in_list false) or "-" (in_list true) of an entry at `column`.
  YamlNode entry_value(int column, int depth, bool in_list) {
    skip_blanks();
    std::string tag;
    if (at(pos_) == '!') {
      const std::size_t begin = pos_;
      std::size_t end = pos_;
      while (!ends_token(end)) ++end;
      tag = std::string(s_.substr(begin, end - begin));
      advance_to(end);
      skip_blanks();
    }
    YamlNode value;
    if (rest_of_line_is_empty()) {
      end_of_line("");
      const auto next = peek();
      if (next && next->column > column) {
        value = block_node(column + 1, depth);
      } else if (!in_list && next && next->column == column && is_list_entry(next->at)) {
        advance_to(next->at);
        value = block_list(column, depth + 1);  // "key:\n- a\n- b": a list at the key's column
      } else {
        value.line = line_;
      }
    } else if (in_list && is_list_entry(pos_)) {
      value = block_list(static_cast<int>(pos_ - line_start_), depth + 1);
    } else if (in_list && starts_map_entry(pos_)) {
      value = block_map(static_cast<int>(pos_ - line_start_), depth + 1);
    } else {
      value = inline_value(depth);
      end_of_line("after the value");
    }
    value.tag = std::move(tag);
    return value;
  }

  /// A value on the rest of the line: a flow list or map, a quoted or a plain scalar.
  YamlNode inline_value(int depth) {
    const char c = at(pos_);
    if (c == '[' || c == '{') return flow_collection(depth + 1);
    if (c == '"' || c == '\'') return quoted_scalar();
    if (c == '|' || c == '>') fail(line_, "block scalars ('|' and '>') are not supported");
    if (c == '&' || c == '*') fail(line_, "anchors and aliases ('&', '*') are not supported");
    if (c == '@' || c == '`' || c == '%')
      fail(line_, std::string("a value cannot start with '") + c + "' (a reserved character; quote the text)");
    YamlNode node;
    node.line = line_;
    std::size_t end = pos_;
    while (!at_end(end) && s_[end] != '\n' && !(s_[end] == '#' && is_blank(s_[end - 1]))) ++end;
    std::string text(s_.substr(pos_, end - pos_));
    while (!text.empty() && is_blank(text.back())) text.pop_back();
    // Strict YAML refuses ": " inside a plain value; OpenCV's reader (and so files written for it,
    // e.g. sensor.yaml comments) takes the rest of the line as the text, and so does this one.
    advance_to(pos_ + text.size());
    node.text = std::move(text);
    type_plain_scalar(node);
    return node;
  }

  YamlNode quoted_scalar() {
    const char quote = s_[pos_];
    YamlNode node;
    node.kind = YamlNode::Kind::text;
    node.line = line_;
    std::size_t p = pos_ + 1;
    for (;;) {
      if (at_end(p) || s_[p] == '\n')
        fail(node.line, std::string("the quoted text is not closed on its line (") + quote + " ... " + quote + ")");
      const char c = s_[p];
      if (quote == '\'' && c == '\'') {
        if (at(p + 1) == '\'') {
          node.text += '\'';
          p += 2;
          continue;
        }
        break;
      }
      if (quote == '"' && c == '"') break;
      if (quote == '"' && c == '\\') {
        static const char kFrom[] = "\\\"/ntr0abefv ";
        static const char kTo[] = "\\\"/\n\t\r\0\a\b\x1b\f\v ";
        const char* found = at_end(p + 1) ? nullptr : std::strchr(kFrom, s_[p + 1]);
        if (found == nullptr || *found == '\0')
          fail(node.line, std::string("the escape '\\") + at(p + 1) + "' is not supported");
        node.text += kTo[found - kFrom];
        p += 2;
        continue;
      }
      node.text += c;
      ++p;
    }
    advance_to(p + 1);
    return node;
  }

  /// Blanks, line ends and comments inside a flow collection.
  void skip_flow_space() {
    std::size_t p = pos_;
    while (!at_end(p)) {
      const char c = s_[p];
      if (is_blank(c) || c == '\n') {
        ++p;
      } else if (c == '#' && (p == 0 || is_blank(s_[p - 1]) || s_[p - 1] == '\n')) {
        while (!at_end(p) && s_[p] != '\n') ++p;
      } else {
        break;
      }
    }
    advance_to(p);
  }

  YamlNode flow_collection(int depth) {
    const char open = s_[pos_];
    const char close = open == '[' ? ']' : '}';
    YamlNode node = start_collection(open == '[' ? YamlNode::Kind::list : YamlNode::Kind::map, depth);
    const auto not_closed = [&] {
      fail(node.line, std::string("the ") + (open == '[' ? "list" : "map") + " opened with '" + open +
                          "' is not closed with '" + close + "'");
    };
    advance_to(pos_ + 1);
    for (;;) {
      skip_flow_space();
      if (at_end(pos_)) not_closed();
      if (s_[pos_] == close) break;
      if (open == '[') {
        node.items.push_back(flow_item(depth, "],"));
      } else {
        const int key_line = line_;
        YamlNode key = flow_item(depth, ":,}");
        if (!key.entries.empty() || !key.items.empty()) fail(key_line, "a key must be a scalar");
        skip_flow_space();
        if (at(pos_) != ':') fail(line_, "expected ':' after the key '" + key.text + "' in a '{' map");
        advance_to(pos_ + 1);
        skip_flow_space();
        for (const auto& [existing, value] : node.entries) {
          if (existing == key.text) fail(key_line, "the key '" + key.text + "' appears twice");
        }
        YamlNode value = flow_item(depth, ",}");
        node.entries.push_back(YamlEntry{key.text, std::move(value)});
      }
      skip_flow_space();
      if (at_end(pos_)) not_closed();
      if (s_[pos_] == ',') {
        advance_to(pos_ + 1);
        continue;
      }
      if (s_[pos_] == close) break;
      fail(line_, std::string("expected ',' or '") + close + "', found '" + excerpt(s_.substr(pos_)) + "'");
    }
    advance_to(pos_ + 1);
    return node;
  }

  /// One entry of a flow collection: a nested collection, a quoted scalar or a plain scalar that
  /// ends at one of `stops`, a line end or a comment.
  YamlNode flow_item(int depth, const char* stops) {
    const char c = at(pos_);
    if (c == '[' || c == '{') return flow_collection(depth + 1);
    if (c == '"' || c == '\'') return quoted_scalar();
    if (c == '&' || c == '*') fail(line_, "anchors and aliases ('&', '*') are not supported");
    if (c == '|' || c == '>' || c == '@' || c == '`' || c == '%' || c == '!' || c == '?')
      fail(line_, std::string("an entry cannot start with '") + c + "' here (quote the text)");
    YamlNode node;
    node.line = line_;
    std::size_t end = pos_;
    while (!at_end(end) && s_[end] != '\n' && std::strchr(stops, s_[end]) == nullptr && s_[end] != '[' &&
           s_[end] != '{' && s_[end] != ']' && s_[end] != '}' && !(s_[end] == '#' && is_blank(s_[end - 1])))
      ++end;
    std::string text(s_.substr(pos_, end - pos_));
    while (!text.empty() && is_blank(text.back())) text.pop_back();
    if (text.empty()) fail(line_, "an empty entry (two commas in a row?)");
    advance_to(pos_ + text.size());
    node.text = std::move(text);
    type_plain_scalar(node);
    return node;
  }

  std::string_view s_;
  std::size_t pos_ = 0;
  std::size_t line_start_ = 0;
  int line_ = 1;
};

}  // namespace

const YamlNode* YamlNode::find(std::string_view key) const {
  if (kind != Kind::map) return nullptr;
  for (const auto& [name, value] : entries)
    if (name == key) return &value;
  return nullptr;
}

std::string YamlNode::describe() const {
  switch (kind) {
    case Kind::null: return "an empty value";
    case Kind::integer:
    case Kind::real: return "a number";
    case Kind::text: return "the text '" + excerpt(text) + "'";
    case Kind::list: return "a list";
    case Kind::map: return "a map";
  }
  return "a value";
}

YamlNode parse_yaml(std::string_view content) { return Parser(content).document(); }

std::optional<std::string> read_yaml_file(const std::filesystem::path& path, YamlNode& root) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const auto status = fs::status(path, ec);
  if (!fs::exists(status)) return std::string("no such file");
  if (fs::is_directory(status)) return std::string("it is a folder, not a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::string("cannot be opened: ") + std::strerror(errno);
  std::string content;
  char buffer[1 << 14];
  while (in.read(buffer, sizeof buffer) || in.gcount() > 0) {
    content.append(buffer, static_cast<std::size_t>(in.gcount()));
    if (content.size() > kMaxYamlBytes)
      return "larger than " + std::to_string(kMaxYamlBytes >> 20) + " MiB: not a settings or sensor file";
  }
  if (in.bad()) return std::string("cannot be read: ") + std::strerror(errno);
  if (content.find_first_not_of(" \t\r\n") == std::string::npos) return std::string("the file is empty");
  if (content.find('\0') != std::string::npos) return std::string("not a YAML file (binary content)");
  try {
    root = parse_yaml(content);
  } catch (const YamlError& e) {
    return std::string("not valid YAML: ") + e.what();
  }
  if (root.is_null()) return std::string("has no keys (only comments and directives)");
  if (root.kind != YamlNode::Kind::map) return std::string("not a YAML map of keys (the document is a list)");
  return std::nullopt;
}

}  // namespace porta::slam::detail
