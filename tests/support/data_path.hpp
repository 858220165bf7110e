// Locating the shared real test data (../shared/data), which a user's checkout may not have.
#pragma once

#include <filesystem>
#include <string>

namespace porta::test {

/// The data folder: $PORTA_DATA_DIR if set, else the path configured at build time.
std::filesystem::path data_dir();

/// Path of `relative` inside the data folder, or empty when it is absent (the caller then calls
/// GTEST_SKIP() with skip_reason()).
std::filesystem::path data_file(const std::string& relative);
std::string skip_reason(const std::string& relative);

}  // namespace porta::test
