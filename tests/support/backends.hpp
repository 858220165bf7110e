// Which backends can run here, for tests that run on every device backend and say why they skip.
#pragma once

#include <string>

namespace porta::test {

/// True when `name` is built into this binary and found a usable device (`portaslam backends`).
bool backend_available(const std::string& name);

}  // namespace porta::test
