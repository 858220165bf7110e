// OpenCL error codes in words, and the check every OpenCL call goes through.
#pragma once

#include <CL/cl.h>

#include <string>

namespace porta::opencl {

/// "CL_OUT_OF_RESOURCES" for -5, "CL_UNKNOWN_ERROR(-1234)" for codes it does not know.
std::string error_name(cl_int code);

/// Throws BackendError "opencl: <call> failed: <NAME> (<code>)[: <what>]" unless code is CL_SUCCESS.
void check(cl_int code, const char* call, const std::string& what = {});

}  // namespace porta::opencl
