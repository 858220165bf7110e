// Small helpers for the portaslam command line: one error type for every mistake a user can make
// on the command line or in an input file, and strict number parsing ("--levels abc" is an error,
// never a silent 0).
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

namespace porta::app {

/// A problem with what the user gave us (an option, a value, a file). main() prints the message on
/// stderr and exits with status 1; the message alone must tell the user what to fix.
class CliError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Parses the whole of `text` as a decimal int, or throws CliError naming `option`.
int parse_int(const std::string& option, const std::string& text);
/// Parses the whole of `text` as a finite decimal number, or throws CliError naming `option`.
double parse_double(const std::string& option, const std::string& text);
/// As above, and the value must lie in [min, max]; the message names the range and repeats the
/// text the user gave (a value beyond 64 bits is reported as given, never wrapped).
int parse_int(const std::string& option, const std::string& text, int min, int max);
double parse_double(const std::string& option, const std::string& text, double min, double max);

/// Worker threads any command accepts (--threads): more than this is a typo, not a machine.
inline constexpr int kMaxThreadsOption = 256;
/// Parses --threads: [0, kMaxThreadsOption], 0 = all hardware threads.
int parse_threads(const std::string& option, const std::string& text);

/// Walks argv left to right. Options may be written "--name value" or "--name=value".
class ArgumentCursor {
 public:
  explicit ArgumentCursor(std::vector<std::string> args) : args_(std::move(args)) {}

  bool done() const { return next_ >= args_.size(); }
  /// The next argument; for "--name=value" only "--name" (the value is kept for value()).
  std::string take();
  /// The value of the option just taken, or CliError "option --name needs a value".
  std::string value(const std::string& option);
  /// True when the option just taken came with "=value" (a flag must not).
  bool has_inline_value() const { return inline_value_.has_value; }

 private:
  struct InlineValue {
    bool has_value = false;
    std::string text;
  };
  std::vector<std::string> args_;
  std::size_t next_ = 0;
  InlineValue inline_value_;
};

}  // namespace porta::app
