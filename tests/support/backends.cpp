#include "support/backends.hpp"

#include "porta/registry.hpp"

namespace porta::test {

BackendInfo backend_info(const std::string& name) {
  for (const BackendInfo& info : BackendRegistry::instance().list())
    if (info.name == name) return info;
  return {};
}

bool backend_available(const std::string& name) { return backend_info(name).available; }

}  // namespace porta::test
