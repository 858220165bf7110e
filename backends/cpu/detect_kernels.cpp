#include "cpu/cpu_backend.hpp"

namespace porta::cpu {
// Kernels of this file: to be written (see DESIGN.md §3).
}  // namespace porta::cpu
