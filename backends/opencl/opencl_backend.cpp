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
  // Profiling is a property of the queue (every OpenCL device supports it).
  queue_ = clCreateCommandQueue(context_, device_.device, options.profile_kernels ? CL_QUEUE_PROFILING_ENABLE : 0,
                                &err);
  check(err, "clCreateCommandQueue", device_.label());
  profile_kernels_ = options.profile_kernels;
  work_groups_ = device_.is_gpu;
  if (const char* env = std::getenv("PORTA_OPENCL_WORK_GROUPS"); env != nullptr && *env != '\0') {
    const std::string value = env;
    if (value != "on" && value != "off")
      throw BackendError("opencl: PORTA_OPENCL_WORK_GROUPS must be on or off, got '" + value + "'");
    work_groups_ = value == "on";
  }
}

OpenClBackend::~OpenClBackend() {
  for (auto& [name, event] : timed_) clReleaseEvent(event);
  scratch_.clear();
  for (auto& [name, k] : kernels_) clReleaseKernel(k);
  for (auto& [name, p] : programs_) clReleaseProgram(p);
  if (queue_) clReleaseCommandQueue(queue_);
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
  const std::string key = std::string(program_name) + "/" + kernel_name;
  if (auto it = kernels_.find(key); it != kernels_.end()) return it->second;
  cl_int err = CL_SUCCESS;
  cl_kernel k = clCreateKernel(program(program_name), kernel_name, &err);
  check(err, "clCreateKernel", key);
  kernels_.emplace(key, k);
  return k;
}

void OpenClBackend::set_arg_raw(cl_kernel k, const char* kernel_name, cl_uint index, std::size_t size,
                                const void* value) {
  check(clSetKernelArg(k, index, size, value), "clSetKernelArg",
        std::string(kernel_name) + " argument " + std::to_string(index));
}

void OpenClBackend::enqueue(cl_kernel k, const char* kernel_name, const Range& range) {
  std::size_t global[2] = {range.global[0], range.global[1]};
  if (global[0] == 0 || (range.dims == 2 && global[1] == 0)) return;
  const bool has_local = range.local[0] != 0;
  if (has_local) {
    for (int d = 0; d < range.dims; ++d) {
      const std::size_t l = range.local[d] ? range.local[d] : 1;
      global[d] = (global[d] + l - 1) / l * l;
    }
  }
  std::size_t local[2] = {range.local[0], range.local[1] ? range.local[1] : 1};
  cl_event event = nullptr;
  check(clEnqueueNDRangeKernel(queue_, k, static_cast<cl_uint>(range.dims), nullptr, global,
                               has_local ? local : nullptr, 0, nullptr, profile_kernels_ ? &event : nullptr),
        "clEnqueueNDRangeKernel", kernel_name);
  if (event != nullptr) timed_.emplace_back(kernel_name, event);
}

void OpenClBackend::read_timed_events() {
  std::vector<std::pair<std::string, cl_event>> timed = std::move(timed_);
  timed_.clear();
  std::string failure;
  for (auto& [name, event] : timed) {
    cl_ulong start = 0, end = 0;
    const cl_int a = clGetEventProfilingInfo(event, CL_PROFILING_COMMAND_START, sizeof(start), &start, nullptr);
    const cl_int b = clGetEventProfilingInfo(event, CL_PROFILING_COMMAND_END, sizeof(end), &end, nullptr);
    clReleaseEvent(event);
    if (a != CL_SUCCESS || b != CL_SUCCESS) {
      if (failure.empty()) failure = name;
      continue;
    }
    profile_.add(name, end >= start ? static_cast<double>(end - start) * 1e-6 : 0.0);
  }
  if (!failure.empty()) check(CL_PROFILING_INFO_NOT_AVAILABLE, "clGetEventProfilingInfo", failure);
}

std::vector<KernelTime> OpenClBackend::kernel_times(bool reset) {
  synchronize();
  return profile_.take(reset);
}

std::unique_ptr<Buffer> OpenClBackend::allocate(std::size_t bytes) {
  cl_int err = CL_SUCCESS;
  cl_mem m = clCreateBuffer(context_, CL_MEM_READ_WRITE, bytes > 0 ? bytes : 1, nullptr, &err);
  check(err, "clCreateBuffer", std::to_string(bytes) + " bytes");
  auto buffer = std::make_unique<OpenClBuffer>(m, bytes);
  fill(*buffer, 0, bytes, 0);
  return buffer;
}

namespace {
void check_range(const Buffer& b, std::size_t offset, std::size_t bytes, const char* call) {
  if (offset > b.size_bytes() || bytes > b.size_bytes() - offset)
    throw BackendError(std::string("opencl: ") + call + ": range [" + std::to_string(offset) + ", +" +
                       std::to_string(bytes) + ") is outside the buffer of " + std::to_string(b.size_bytes()) +
                       " bytes");
}
}  // namespace

void OpenClBackend::upload(Buffer& dst, std::size_t dst_offset, const void* src, std::size_t bytes) {
  check_range(dst, dst_offset, bytes, "upload");
  if (bytes == 0) return;
  check(clEnqueueWriteBuffer(queue_, mem_of(dst), CL_TRUE, dst_offset, bytes, src, 0, nullptr, nullptr),
        "clEnqueueWriteBuffer");
}

void OpenClBackend::download(const Buffer& src, std::size_t src_offset, void* dst, std::size_t bytes) {
  check_range(src, src_offset, bytes, "download");
  if (bytes == 0) return;
  check(clEnqueueReadBuffer(queue_, mem_of(src), CL_TRUE, src_offset, bytes, dst, 0, nullptr, nullptr),
        "clEnqueueReadBuffer");
}

void OpenClBackend::fill(Buffer& dst, std::size_t offset, std::size_t bytes, std::uint8_t value) {
  check_range(dst, offset, bytes, "fill");
  if (bytes == 0) return;
  check(clEnqueueFillBuffer(queue_, mem_of(dst), &value, 1, offset, bytes, 0, nullptr, nullptr),
        "clEnqueueFillBuffer");
}

void OpenClBackend::synchronize() {
  check(clFinish(queue_), "clFinish");
  read_timed_events();  // complete now; their events are not kept past a synchronize
}

Buffer& OpenClBackend::scratch(const std::string& name, std::size_t bytes) {
  auto& slot = scratch_[name];
  if (!slot || slot->size_bytes() < bytes) slot = allocate(bytes);
  return *slot;
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
