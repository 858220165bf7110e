#include "output_paths.hpp"

#include <fstream>
#include <system_error>
#include <unistd.h>

#include "cli_args.hpp"

namespace fs = std::filesystem;

namespace porta::app {

namespace {

void refuse_empty_or_root(const std::string& option, const std::string& text, const char* what) {
  if (text.empty()) throw CliError("option " + option + " expects " + what + ", got an empty path");
  std::error_code error;
  const fs::path absolute = fs::weakly_canonical(fs::absolute(text, error), error);
  if (!error && absolute == absolute.root_path()) {
    throw CliError("option " + option + " must not name the filesystem root ('" + text + "'): give a folder of " +
                   "its own, e.g. " + option + " portaslam-out");
  }
}

/// "run", "run/" and "./run" are the same folder.
bool same_folder(const fs::path& a, const fs::path& b) {
  const auto normal = [](const fs::path& p) {
    fs::path n = p.lexically_normal();
    return n.has_filename() || n == n.root_path() ? n : n.parent_path();
  };
  return normal(a) == normal(b);
}

}  // namespace

void check_output_folder(const std::string& option, const std::string& text) {
  refuse_empty_or_root(option, text, "a folder");
  std::error_code error;
  if (fs::exists(text, error) && !fs::is_directory(text, error))
    throw CliError("option " + option + ": '" + text + "' is a file, not a folder");
}

fs::path prepare_output_folder(const std::string& option, const std::string& text) {
  check_output_folder(option, text);
  const fs::path folder(text);
  std::error_code error;
  fs::create_directories(folder, error);
  if (error || !fs::is_directory(folder))
    throw CliError("option " + option + ": cannot create the folder '" + text + "'" +
                   (error ? ": " + error.message() : std::string()));
  return folder;
}

void check_output_file(const std::string& option, const std::string& text, const std::string& pending_folder) {
  refuse_empty_or_root(option, text, "a file");
  const fs::path file(text);
  const fs::path parent = file.parent_path().empty() ? fs::path(".") : file.parent_path();
  std::error_code error;
  if (fs::is_directory(file, error)) throw CliError("option " + option + ": '" + text + "' is a folder, not a file");
  if (!pending_folder.empty() && !fs::exists(parent, error) &&
      same_folder(parent, pending_folder))
    return;
  if (!fs::is_directory(parent, error))
    throw CliError("option " + option + ": cannot write '" + text + "': the folder '" + parent.string() +
                   "' does not exist");
  const fs::path probe = parent / (".portaslam-write-test-" + std::to_string(::getpid()));
  {
    std::ofstream test(probe);
    if (!test)
      throw CliError("option " + option + ": cannot write '" + text + "': the folder '" + parent.string() +
                     "' does not take files");
  }
  fs::remove(probe, error);
}

}  // namespace porta::app
