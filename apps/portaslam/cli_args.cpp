#include "cli_args.hpp"

#include <charconv>
#include <cmath>
#include <limits>
#include <sstream>
#include <system_error>

namespace porta::app {

int parse_int(const std::string& option, const std::string& text) {
  return parse_int(option, text, std::numeric_limits<int>::min(), std::numeric_limits<int>::max());
}

int parse_int(const std::string& option, const std::string& text, int min, int max) {
  const auto range = [&] {
    const bool whole = min == std::numeric_limits<int>::min() && max == std::numeric_limits<int>::max();
    return whole ? std::string() : " in [" + std::to_string(min) + ", " + std::to_string(max) + "]";
  };
  long long value = 0;
  const char* first = text.data();
  const char* last = text.data() + text.size();
  if (!text.empty() && *first == '+') ++first;  // from_chars rejects a leading '+'; users write it
  const auto [end, error] = std::from_chars(first, last, value);
  if (text.empty() || (error != std::errc() && error != std::errc::result_out_of_range) || end != last)
    throw CliError("option " + option + " expects an integer" + range() + ", got '" + text + "'");
  if (error == std::errc::result_out_of_range || value < min || value > max)
    throw CliError("option " + option + " expects an integer" + range() + ", got '" + text + "' (out of range)");
  return static_cast<int>(value);
}

double parse_double(const std::string& option, const std::string& text) {
  double value = 0.0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || error != std::errc() || end != text.data() + text.size() || !std::isfinite(value))
    throw CliError("option " + option + " expects a number, got '" + text + "'");
  return value;
}

double parse_double(const std::string& option, const std::string& text, double min, double max) {
  const double value = parse_double(option, text);
  if (value < min || value > max) {
    std::ostringstream range;
    range << "[" << min << ", " << max << "]";
    throw CliError("option " + option + " expects a number in " + range.str() + ", got '" + text + "'");
  }
  return value;
}

int parse_threads(const std::string& option, const std::string& text) {
  return parse_int(option, text, 0, kMaxThreadsOption);
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
