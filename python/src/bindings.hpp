// The parts of the portaslam Python module, each defined in its own file.
#pragma once

#include <pybind11/pybind11.h>

namespace porta::python {

void bind_frontend(pybind11::module_& m);  // frontend_bindings.cpp
void bind_slam(pybind11::module_& m);      // slam_bindings.cpp

}  // namespace porta::python
