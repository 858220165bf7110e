// Which backends can run here, for tests that run on every device backend and say why they skip.
#pragma once

#include <string>

#include "porta/registry.hpp"

namespace porta::test {

/// The registry's entry for `name` (not built: available false, empty detail).
BackendInfo backend_info(const std::string& name);

/// True when `name` is built into this binary and found a usable device (`portaslam backends`).
bool backend_available(const std::string& name);

}  // namespace porta::test
