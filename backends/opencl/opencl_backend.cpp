#include "opencl/opencl_backend.hpp"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "opencl/cl_errors.hpp"
#include "porta/embedded_text.hpp"

namespace porta::opencl {

extern const EmbeddedText kEmbedded[];  // generated from shaders/opencl/*.cl
extern const int kEmbeddedCount;

namespace {

std::string platform_info(cl_platform_id p, cl_platform_info what) {
  std::size_t n = 0;
  if (clGetPlatformInfo(p, what, 0, nullptr, &n) != CL_SUCCESS || n == 0) return "?";
  std::string s(n, '\0');
  clGetPlatformInfo(p, what, n, s.data(), nullptr);
  s.resize(std::strlen(s.c_str()));
  return s;
}

std::string device_info(cl_device_id d, cl_device_info what) {
  std::size_t n = 0;
  if (clGetDeviceInfo(d, what, 0, nullptr, &n) != CL_SUCCESS || n == 0) return "?";
  std::string s(n, '\0');
  clGetDeviceInfo(d, what, n, s.data(), nullptr);
  s.resize(std::strlen(s.c_str()));
  return s;
}

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string list_devices(const std::vector<DeviceEntry>& devices) {
  std::ostringstream out;
  for (std::size_t i = 0; i < devices.size(); ++i) out << (i ? "; " : "") << "[" << i << "] " << devices[i].label();
  return devices.empty() ? std::string("none (no OpenCL platform/ICD installed)") : out.str();
}

DeviceEntry select_device(const BackendOptions& options) {
  const auto devices = enumerate_devices();
  if (devices.empty())
    throw BackendError("opencl: no OpenCL device found (install an ICD, e.g. Debian's pocl-opencl-icd, "
                       "or the GPU vendor's OpenCL driver)");
  std::string want = options.device;
  if (want.empty()) {
    if (const char* env = std::getenv("PORTA_OPENCL_DEVICE"); env && *env) want = env;
  }
  if (want.empty()) {
    auto gpu = std::find_if(devices.begin(), devices.end(), [](const DeviceEntry& d) { return d.is_gpu; });
    return gpu != devices.end() ? *gpu : devices.front();
  }
  if (std::all_of(want.begin(), want.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); })) {
    const auto index = std::stoul(want);
    if (index < devices.size()) return devices[index];
  } else {
    for (const auto& d : devices)
      if (lower(d.label()).find(lower(want)) != std::string::npos) return d;
  }
  throw BackendError("opencl: no device matches '" + want + "' (from --device or PORTA_OPENCL_DEVICE); devices found: " +
                     list_devices(devices));
}

// FNV-1a, enough to name a cache file.
std::uint64_t fnv1a(const std::string& s) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : s) h = (h ^ c) * 1099511628211ull;
  return h;
}

std::filesystem::path cache_dir() {
  if (const char* off = std::getenv("PORTA_OPENCL_CACHE"); off && std::string(off) == "0") return {};
  if (const char* d = std::getenv("PORTA_CACHE_DIR"); d && *d) return std::filesystem::path(d) / "opencl";
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return std::filesystem::path(x) / "portaslam" / "opencl";
  if (const char* h = std::getenv("HOME"); h && *h) return std::filesystem::path(h) / ".cache" / "portaslam" / "opencl";
  return {};
}

constexpr const char* kBuildOptions = "-cl-std=CL1.2";

}  // namespace

std::vector<DeviceEntry> enumerate_devices() {
  std::vector<DeviceEntry> out;
  cl_uint num_platforms = 0;
  if (clGetPlatformIDs(0, nullptr, &num_platforms) != CL_SUCCESS || num_platforms == 0) return out;
  std::vector<cl_platform_id> platforms(num_platforms);
  clGetPlatformIDs(num_platforms, platforms.data(), nullptr);
  for (cl_platform_id p : platforms) {
    cl_uint num_devices = 0;
    if (clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, 0, nullptr, &num_devices) != CL_SUCCESS || num_devices == 0) continue;
    std::vector<cl_device_id> devices(num_devices);
    clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, num_devices, devices.data(), nullptr);
    for (cl_device_id d : devices) {
      cl_device_type type = 0;
      clGetDeviceInfo(d, CL_DEVICE_TYPE, sizeof(type), &type, nullptr);
      out.push_back({p, d, platform_info(p, CL_PLATFORM_NAME), device_info(d, CL_DEVICE_NAME),
                     (type & CL_DEVICE_TYPE_GPU) != 0});
    }
  }
  return out;
}

OpenClBuffer::~OpenClBuffer() {
  if (mem_) clReleaseMemObject(mem_);
}

OpenClBackend::OpenClBackend(const BackendOptions& options) : device_(select_device(options)) {
  cl_int err = CL_SUCCESS;
  const cl_context_properties props[] = {CL_CONTEXT_PLATFORM,
                                         reinterpret_cast<cl_context_properties>(device_.platform), 0};
  context_ = clCreateContext(props, 1, &device_.device, nullptr, nullptr, &err);
  check(err, "clCreateContext", device_.label());
  queue_count_ = kQueues;
  if (const char* env = std::getenv("PORTA_OPENCL_QUEUES"); env != nullptr && *env != '\0') {
    char* end = nullptr;
    const long n = std::strtol(env, &end, 10);
    if (end == env || *end != '\0' || n < 1 || n > kQueues)
      throw BackendError("opencl: PORTA_OPENCL_QUEUES must be a queue count from 1 to " + std::to_string(kQueues) +
                         ", got '" + env + "'");
    queue_count_ = static_cast<int>(n);
  }
  // In-order queues; profiling is a property of the queue (every OpenCL device supports it).
  for (int q = 0; q < queue_count_; ++q) {
    queues_[static_cast<std::size_t>(q)] = clCreateCommandQueue(
        context_, device_.device, options.profile_kernels ? CL_QUEUE_PROFILING_ENABLE : 0, &err);
    check(err, "clCreateCommandQueue", device_.label());
  }
  profile_kernels_ = options.profile_kernels;
  // The work-group kernels run up to 256 work-items per group (32 x 8 in the tiled ones).
  check(clGetDeviceInfo(device_.device, CL_DEVICE_MAX_WORK_GROUP_SIZE, sizeof(max_work_group_), &max_work_group_,
                        nullptr),
        "clGetDeviceInfo(CL_DEVICE_MAX_WORK_GROUP_SIZE)", device_.label());
  work_groups_ = checks::env_switch("opencl", "PORTA_OPENCL_WORK_GROUPS", device_.is_gpu && max_work_group_ >= 256);
  // On by default where the work-group kernels run (GPUs): one launch per image instead of one per
  // level, which the NVIDIA driver's ~5 us per enqueue makes pay with frames in flight (H200: 4 in
  // flight, stereo 313 -> 245 us per pair). On CPU devices (PoCL) a work-group per tile of every
  // level runs at half the speed of a launch per level, so off there (docs/BENCHMARKS.md).
  fused_pyramid_ = checks::env_switch("opencl", "PORTA_OPENCL_FUSED_PYRAMID", work_groups_);
  // Detection in fewer launches (FAST with culling, PFA with compaction) where the work-group
  // kernels run (GPUs): each launch saved is ~5 us of the host's time on NVIDIA's OpenCL.
  fused_detect_ = checks::env_switch("opencl", "PORTA_OPENCL_FUSED_DETECT", work_groups_);
  pfa_in_cull_ = checks::env_switch("opencl", "PORTA_OPENCL_PFA_IN_CULL", true);
}

OpenClBackend::~OpenClBackend() {
  for (cl_command_queue q : queues_)
    if (q) clFinish(q);  // work in flight writes into memory about to go
  for (auto& t : timed_) clReleaseEvent(t.event);
  scratch_.clear();
  for (auto& [name, k] : kernels_) clReleaseKernel(k);
  for (auto& [name, p] : programs_) clReleaseProgram(p);
  for (cl_command_queue q : queues_)
    if (q) clReleaseCommandQueue(q);
  if (context_) clReleaseContext(context_);
}

cl_program OpenClBackend::build_program(const std::string& name, const std::string& source) {
  cl_program program = nullptr;
  const std::string key = source + '\n' + device_.label() + '\n' + device_info(device_.device, CL_DEVICE_VERSION) +
                          '\n' + device_info(device_.device, CL_DRIVER_VERSION) + '\n' + kBuildOptions;
  std::filesystem::path cached;
  if (const auto dir = cache_dir(); !dir.empty()) {
    std::ostringstream name;
    name << std::hex << fnv1a(key) << ".clbin";
    cached = dir / name.str();
  }
  cl_int err = CL_SUCCESS;
  // A cached binary for exactly this source, device and driver skips the compiler.
  if (!cached.empty() && std::filesystem::exists(cached)) {
    std::ifstream in(cached, std::ios::binary);
    const std::vector<unsigned char> bin((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const unsigned char* ptr = bin.data();
    const std::size_t size = bin.size();
    cl_int status = CL_SUCCESS;
    program = clCreateProgramWithBinary(context_, 1, &device_.device, &size, &ptr, &status, &err);
    if (err == CL_SUCCESS && status == CL_SUCCESS &&
        clBuildProgram(program, 1, &device_.device, kBuildOptions, nullptr, nullptr) == CL_SUCCESS)
      return program;
    if (program) clReleaseProgram(program);
    program = nullptr;
  }
  const char* text = source.c_str();
  program = clCreateProgramWithSource(context_, 1, &text, nullptr, &err);
  check(err, "clCreateProgramWithSource", name + ".cl on " + device_.label());
  err = clBuildProgram(program, 1, &device_.device, kBuildOptions, nullptr, nullptr);
  if (err != CL_SUCCESS) {
    std::size_t n = 0;
    clGetProgramBuildInfo(program, device_.device, CL_PROGRAM_BUILD_LOG, 0, nullptr, &n);
    std::string log(n, '\0');
    clGetProgramBuildInfo(program, device_.device, CL_PROGRAM_BUILD_LOG, n, log.data(), nullptr);
    clReleaseProgram(program);
    check(err, "clBuildProgram", name + ".cl on " + device_.label() + "; build log:\n" + log);
  }
  if (cached.empty()) return program;
  std::size_t size = 0;
  if (clGetProgramInfo(program, CL_PROGRAM_BINARY_SIZES, sizeof(size), &size, nullptr) != CL_SUCCESS || size == 0)
    return program;
  std::vector<unsigned char> bin(size);
  unsigned char* ptr = bin.data();
  if (clGetProgramInfo(program, CL_PROGRAM_BINARIES, sizeof(ptr), &ptr, nullptr) != CL_SUCCESS) return program;
  std::error_code ec;
  std::filesystem::create_directories(cached.parent_path(), ec);
  const auto tmp = cached.string() + ".tmp" + std::to_string(fnv1a(std::to_string(reinterpret_cast<std::uintptr_t>(this))));
  {
    std::ofstream out(tmp, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bin.data()), static_cast<std::streamsize>(bin.size()));
  }
  std::filesystem::rename(tmp, cached, ec);  // atomic: concurrent tests never read half a file
  return program;
}

cl_program OpenClBackend::program(const char* name) {
  if (auto it = programs_.find(name); it != programs_.end()) return it->second;
  const EmbeddedText* common = nullptr;
  const EmbeddedText* file = nullptr;
  for (int i = 0; i < kEmbeddedCount; ++i) {
    if (std::string(kEmbedded[i].name) == "common") common = &kEmbedded[i];
    if (std::string(kEmbedded[i].name) == name) file = &kEmbedded[i];
  }
  if (!file) throw BackendError(std::string("opencl: no embedded program '") + name + "'");
  const std::string source = std::string(common ? common->text : "") + "\n" + file->text;
  cl_program p = build_program(name, source);
  programs_.emplace(name, p);
  return p;
}


cl_kernel OpenClBackend::kernel(const char* program_name, const char* kernel_name) {
  // Every launch passes string literals: found by their addresses without building a string.
  if (auto it = kernels_by_address_.find({program_name, kernel_name}); it != kernels_by_address_.end())
    return it->second;
  const std::string key = std::string(program_name) + "/" + kernel_name;
  auto it = kernels_.find(key);
  if (it == kernels_.end()) {
    cl_int err = CL_SUCCESS;
    cl_kernel k = clCreateKernel(program(program_name), kernel_name, &err);
    check(err, "clCreateKernel", key);
    it = kernels_.emplace(key, k).first;
  }
  kernels_by_address_.emplace(std::make_pair(program_name, kernel_name), it->second);
  return it->second;
}

void OpenClBackend::set_arg_raw(cl_kernel k, const char* kernel_name, cl_uint index, std::size_t size,
                                const void* value) {
  // The message is built only on failure: this runs for every argument of every launch.
  if (const cl_int err = clSetKernelArg(k, index, size, value); err != CL_SUCCESS)
    check(err, "clSetKernelArg", std::string(kernel_name) + " argument " + std::to_string(index));
}

}  // namespace porta::opencl

namespace porta {

void register_opencl_backend(BackendRegistry& registry) {
  registry.add(
      "opencl",
      [] {
        BackendInfo info{"opencl", true, false, {}};
        const auto devices = opencl::enumerate_devices();
        info.available = !devices.empty();
        info.detail = devices.empty() ? "no OpenCL device found (no platform/ICD installed)" : opencl::list_devices(devices);
        return info;
      },
      [](const BackendOptions& options) -> std::unique_ptr<Backend> {
        return std::make_unique<opencl::OpenClBackend>(options);
      });
}

}  // namespace porta
