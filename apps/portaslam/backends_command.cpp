// `portaslam backends`: what this binary was built with and what can run on this machine, straight
// from the engine's registry (DESIGN.md §4), so a user can tell why `--backend X` fails.
#include <algorithm>
#include <iomanip>
#include <iostream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "porta/registry.hpp"

namespace porta::app {

int backends_command(const std::vector<std::string>& args) {
  if (!args.empty() && (args[0] == "--help" || args[0] == "-h")) {
    std::cout << "Usage: portaslam backends\n";
    return 0;
  }
  if (!args.empty()) {
    std::cerr << "portaslam backends: unexpected argument '" << args[0] << "' (the command takes none)\n";
    return 1;
  }
  const std::vector<BackendInfo> backends = BackendRegistry::instance().list();
  std::size_t name_width = 7;
  for (const auto& b : backends) name_width = std::max(name_width, b.name.size());
  auto row = [&](const std::string& name, const std::string& built, const std::string& available,
                 const std::string& detail) {
    std::cout << std::left << std::setw(static_cast<int>(name_width) + 2) << name << std::setw(7) << built
              << std::setw(11) << available << detail << '\n';
  };
  row("backend", "built", "available", "detail");
  int usable = 0;
  for (const auto& b : backends) {
    row(b.name, b.compiled ? "yes" : "no", b.available ? "yes" : "no", b.detail);
    usable += b.available ? 1 : 0;
  }
  std::cout << '\n'
            << usable << " of " << backends.size()
            << " backends usable here; pick one with `portaslam features --backend NAME`.\n";
  return 0;
}

}  // namespace porta::app
