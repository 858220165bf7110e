#include "support/backends.hpp"

#include "porta/registry.hpp"

namespace porta::test {

bool backend_available(const std::string& name) {
  for (const BackendInfo& info : BackendRegistry::instance().list())
    if (info.name == name) return info.available;
  return false;
}

}  // namespace porta::test
