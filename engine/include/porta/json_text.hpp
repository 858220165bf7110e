// JSON string literals for the reports the tools write (summary.json, bench and evaluation JSON).
#pragma once

#include <cstdio>
#include <string>
#include <string_view>

namespace porta {

/// `text` as a JSON string literal: quotes, backslashes, newlines and tabs escaped with a
/// backslash, other control characters as \uXXXX; other bytes (UTF-8 included) as they are.
inline std::string json_string(std::string_view text) {
  std::string out = "\"";
  for (const char c : text) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char escaped[8];
          std::snprintf(escaped, sizeof escaped, "\\u%04x", static_cast<unsigned>(static_cast<unsigned char>(c)));
          out += escaped;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

}  // namespace porta
