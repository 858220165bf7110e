#include "cli_args.hpp"

#include <charconv>
#include <cmath>
#include <system_error>

namespace porta::app {

int parse_int(const std::string& option, const std::string& text) {
  int value = 0;
  const char* first = text.data();
  const char* last = text.data() + text.size();
  if (!text.empty() && *first == '+') ++first;  // from_chars rejects a leading '+'; users write it
  const auto [end, error] = std::from_chars(first, last, value);
  if (error == std::errc::result_out_of_range)
    throw CliError("option " + option + " expects an integer, got '" + text + "' (out of range)");
  if (text.empty() || error != std::errc() || end != last)
    throw CliError("option " + option + " expects an integer, got '" + text + "'");
  return value;
}

double parse_double(const std::string& option, const std::string& text) {
  double value = 0.0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || error != std::errc() || end != text.data() + text.size() || !std::isfinite(value))
    throw CliError("option " + option + " expects a number, got '" + text + "'");
  return value;
}

std::string ArgumentCursor::take() {
  std::string arg = args_.at(next_++);
  inline_value_ = {};
  const auto equals = arg.find('=');
  if (arg.rfind("--", 0) == 0 && equals != std::string::npos) {
    inline_value_ = {true, arg.substr(equals + 1)};
    arg.resize(equals);
  }
  return arg;
}

std::string ArgumentCursor::value(const std::string& option) {
  if (inline_value_.has_value) {
    inline_value_.has_value = false;
    return inline_value_.text;
  }
  // A following option ("--levels --scale 1.3") is a missing value, not the value "--scale";
  // negative numbers ("-1") are still values.
  if (done() || args_[next_].rfind("--", 0) == 0) throw CliError("option " + option + " needs a value");
  return args_[next_++];
}

}  // namespace porta::app
