// Where the portaslam commands may write: every output folder or file the user names is checked
// here before any work starts, so that a long run never fails at its end for a bad path, and
// nothing is written outside the place the user named (an empty path or the filesystem root is
// refused: "--dir ''" must not become "/sequence").
#pragma once

#include <filesystem>
#include <string>

namespace porta::app {

/// `text` as an output folder for `option`: refuses an empty path, the filesystem root and a file;
/// creates the folder (and its parents). Throws CliError naming the option and the path.
std::filesystem::path prepare_output_folder(const std::string& option, const std::string& text);

/// The checks of prepare_output_folder without creating anything (the writer creates it later).
void check_output_folder(const std::string& option, const std::string& text);

/// `text` as an output file for `option`: refuses an empty path, a folder, and a file whose folder
/// does not exist or does not take files (probed by creating and removing a file there).
/// `pending_folder`: an output folder that is checked but not created yet (the run's --out); a file
/// directly inside it passes without the probe.
void check_output_file(const std::string& option, const std::string& text, const std::string& pending_folder = "");

}  // namespace porta::app
