#include "support/data_path.hpp"

#include <cstdlib>

namespace porta::test {

std::filesystem::path data_dir() {
  if (const char* env = std::getenv("PORTA_DATA_DIR"); env && *env) return env;
  return PORTA_DATA_DIR;
}

std::filesystem::path data_file(const std::string& relative) {
  auto p = data_dir() / relative;
  return std::filesystem::exists(p) ? p : std::filesystem::path{};
}

std::string skip_reason(const std::string& relative) {
  return "shared test data not found: " + (data_dir() / relative).string() +
         " is absent (set PORTA_DATA_DIR to the folder of ../shared/data)";
}

}  // namespace porta::test
