#include "porta/registry.hpp"

#include <algorithm>

namespace porta {

const std::vector<std::string>& known_backend_names() {
  static const std::vector<std::string> names = {"cpu", "cuda", "vulkan", "opencl"};
  return names;
}

// BackendRegistry::instance() is defined in backends/builtin.cpp, the one place that knows which
// backends this build has; the engine itself depends on none of them.

void BackendRegistry::add(std::string name, BackendProbe probe, BackendFactory factory) {
  entries_.push_back({std::move(name), std::move(probe), std::move(factory)});
}

std::vector<BackendInfo> BackendRegistry::list() const {
  std::vector<BackendInfo> out;
  for (const auto& name : known_backend_names()) {
    auto it = std::find_if(entries_.begin(), entries_.end(), [&](const Entry& e) { return e.name == name; });
    if (it == entries_.end()) {
      out.push_back({name, false, false, "not built into this binary (configure with -DPORTA_WITH_" +
                                             [&] {
                                               std::string u = name;
                                               for (auto& c : u) c = static_cast<char>(std::toupper(c));
                                               return u;
                                             }() +
                                             "=ON)"});
      continue;
    }
    try {
      out.push_back(it->probe());
    } catch (const std::exception& e) {
      out.push_back({name, true, false, e.what()});
    }
  }
  return out;
}

std::unique_ptr<Backend> BackendRegistry::create(const std::string& name, const BackendOptions& options) const {
  auto it = std::find_if(entries_.begin(), entries_.end(), [&](const Entry& e) { return e.name == name; });
  if (it != entries_.end()) return it->factory(options);
  const auto& known = known_backend_names();
  if (std::find(known.begin(), known.end(), name) == known.end())
    throw BackendError("unknown backend '" + name + "': choose one of cpu, cuda, vulkan, opencl");
  std::string built;
  for (const auto& e : entries_) built += (built.empty() ? "" : ", ") + e.name;
  throw BackendError("backend '" + name + "' is not built into this binary (built: " + built +
                     "); install its toolchain and reconfigure, see README.md");
}

}  // namespace porta
