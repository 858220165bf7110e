#include "cuda/cuda_backend.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdlib>
#include <cstring>
#include <sstream>

#include "cuda/cuda_errors.hpp"
#include "cuda/kernels.hpp"

#ifndef PORTA_CUDA_ARCHS
#define PORTA_CUDA_ARCHS "unknown"
#endif

namespace porta::cuda {

namespace {

/// Transfers go through the pinned staging buffer in chunks of at most this many bytes.
constexpr std::size_t kStagingLimit = std::size_t{8} << 20;
constexpr int kDefaultMlptNmax = 8;
constexpr int kMaxMlptNmax = 1024;

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string runtime_version() {
  return std::to_string(CUDART_VERSION / 1000) + "." + std::to_string(CUDART_VERSION % 1000 / 10);
}

DeviceEntry select_device(const BackendOptions& options) {
  std::string why;
  const auto devices = enumerate_devices(&why);
  if (devices.empty()) throw BackendError("cuda: no CUDA device (" + why + ")");
  std::string want = options.device;
  if (want.empty()) {
    if (const char* env = std::getenv("PORTA_CUDA_DEVICE"); env && *env) want = env;
  }
  if (want.empty()) return devices.front();
  if (std::all_of(want.begin(), want.end(),
                  [](char c) { return std::isdigit(static_cast<unsigned char>(c)); })) {
    unsigned long index = 0;
    const auto [end, ec] = std::from_chars(want.data(), want.data() + want.size(), index);
    if (ec == std::errc() && end == want.data() + want.size() && index < devices.size())
      return devices[index];
  } else {
    for (const auto& d : devices)
      if (lower(d.name).find(lower(want)) != std::string::npos) return d;
  }
  throw BackendError("cuda: no device matches '" + want +
                     "' (from --device or PORTA_CUDA_DEVICE: an index or part of the name); devices found: " +
                     list_devices(devices));
}

int read_mlpt_nmax() {
  const char* env = std::getenv("PORTA_CUDA_MLPT_NMAX");
  if (env == nullptr || *env == '\0') return kDefaultMlptNmax;
  const std::string text = env;
  int value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || end != text.data() + text.size() || value < 1 || value > kMaxMlptNmax)
    throw BackendError("cuda: PORTA_CUDA_MLPT_NMAX='" + text + "' is not an integer in [1, " +
                       std::to_string(kMaxMlptNmax) + "] (the rows one culling thread scans; default " +
                       std::to_string(kDefaultMlptNmax) + ")");
  return value;
}

void check_range(const Buffer& b, std::size_t offset, std::size_t bytes, const char* call) {
  if (offset > b.size_bytes() || bytes > b.size_bytes() - offset)
    throw BackendError(std::string("cuda: ") + call + ": range [" + std::to_string(offset) + ", +" +
                       std::to_string(bytes) + ") is outside the buffer of " +
                       std::to_string(b.size_bytes()) + " bytes");
}

}  // namespace

std::string DeviceEntry::label() const {
  return name + " (sm_" + std::to_string(major) + std::to_string(minor) + ", " +
         std::to_string((memory_bytes + (std::size_t{1} << 29)) >> 30) + " GiB)";
}

std::vector<DeviceEntry> enumerate_devices(std::string* why) {
  std::vector<DeviceEntry> out;
  int count = 0;
  const cudaError_t err = cudaGetDeviceCount(&count);
  if (err != cudaSuccess) {
    static_cast<void>(cudaGetLastError());
    if (why) {
      *why = "cudaGetDeviceCount: " + error_text(err);
      if (err == cudaErrorInsufficientDriver || err == cudaErrorNoDevice)
        *why += "; this build needs an NVIDIA GPU and a driver for CUDA " + runtime_version() + " or newer";
    }
    return out;
  }
  if (count <= 0) {
    if (why) *why = "cudaGetDeviceCount found 0 devices";
    return out;
  }
  for (int i = 0; i < count; ++i) {
    DeviceEntry d;
    d.index = i;
    cudaDeviceProp prop{};
    if (const cudaError_t e = cudaGetDeviceProperties(&prop, i); e != cudaSuccess) {
      static_cast<void>(cudaGetLastError());
      d.name = "device " + std::to_string(i) + " (cudaGetDeviceProperties: " + error_text(e) + ")";
    } else {
      d.name = prop.name;
      d.major = prop.major;
      d.minor = prop.minor;
      d.memory_bytes = prop.totalGlobalMem;
    }
    out.push_back(d);
  }
  return out;
}

std::string list_devices(const std::vector<DeviceEntry>& devices) {
  if (devices.empty()) return "none";
  std::ostringstream out;
  for (std::size_t i = 0; i < devices.size(); ++i)
    out << (i ? "; " : "") << "[" << i << "] " << devices[i].label();
  return out.str();
}

CudaBuffer::~CudaBuffer() {
  if (ptr_ == nullptr) return;
  // Free on the device that owns the memory, and leave the thread's current device as it was.
  int current = -1;
  const bool switch_device = cudaGetDevice(&current) == cudaSuccess && current != device_;
  if (switch_device) static_cast<void>(cudaSetDevice(device_));
  static_cast<void>(cudaFree(ptr_));  // a destructor cannot throw; a failure here leaks at worst
  if (switch_device) static_cast<void>(cudaSetDevice(current));
}

CudaBackend::CudaBackend(const BackendOptions& options)
    : device_(select_device(options)), mlpt_nmax_(read_mlpt_nmax()) {
  check(cudaSetDevice(device_.index), "cudaSetDevice(" + std::to_string(device_.index) + ")",
        device_.label());
  if (const cudaError_t e = probe_kernel_image(); e != cudaSuccess) {
    static_cast<void>(cudaGetLastError());
    throw BackendError("cuda: " + device_.label() +
                       " cannot run this build's kernels (built for CUDA architectures " + PORTA_CUDA_ARCHS +
                       "; reconfigure with -DCMAKE_CUDA_ARCHITECTURES=" + std::to_string(device_.major) +
                       std::to_string(device_.minor) + "): " + error_text(e));
  }
  check(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking), "cudaStreamCreateWithFlags",
        device_.label());
  if (const cudaError_t e = cudaEventCreateWithFlags(&staging_free_, cudaEventDisableTiming);
      e != cudaSuccess) {
    static_cast<void>(cudaStreamDestroy(stream_));
    check(e, "cudaEventCreateWithFlags", device_.label());
  }
}

CudaBackend::~CudaBackend() {
  // Destructors cannot throw: errors here are ignored (the memory goes with the process at worst).
  static_cast<void>(cudaSetDevice(device_.index));
  static_cast<void>(cudaStreamSynchronize(stream_));
  scratch_.clear();
  if (staging_) static_cast<void>(cudaFreeHost(staging_));
  if (staging_free_) static_cast<void>(cudaEventDestroy(staging_free_));
  if (stream_) static_cast<void>(cudaStreamDestroy(stream_));
}

void CudaBackend::activate() const {
  check(cudaSetDevice(device_.index), "cudaSetDevice(" + std::to_string(device_.index) + ")",
        device_.label());
}

std::unique_ptr<Buffer> CudaBackend::allocate(std::size_t bytes) {
  activate();
  void* ptr = nullptr;
  const std::size_t n = bytes > 0 ? bytes : 1;
  check(cudaMalloc(&ptr, n), "cudaMalloc(" + std::to_string(bytes) + " bytes)");
  auto buffer = std::make_unique<CudaBuffer>(static_cast<std::uint8_t*>(ptr), bytes, device_.index);
  check(cudaMemsetAsync(ptr, 0, n, stream_), "cudaMemsetAsync(" + std::to_string(n) + " bytes, zero-fill)");
  return buffer;
}

void* CudaBackend::staging(std::size_t bytes) {
  // The staging memory may still be read by the last upload's copy.
  check(cudaEventSynchronize(staging_free_), "cudaEventSynchronize(staging)");
  if (bytes > staging_bytes_) {
    if (staging_) {
      void* old = staging_;
      staging_ = nullptr;
      staging_bytes_ = 0;
      check(cudaFreeHost(old), "cudaFreeHost(staging)");
    }
    check(cudaHostAlloc(&staging_, bytes, cudaHostAllocDefault),
          "cudaHostAlloc(" + std::to_string(bytes) + " bytes)");
    staging_bytes_ = bytes;
  }
  return staging_;
}

// The upload returns once the source has been copied to pinned memory; the copy to the device
// runs on the stream, in order with the kernels.
void CudaBackend::upload(Buffer& dst, std::size_t dst_offset, const void* src, std::size_t bytes) {
  check_range(dst, dst_offset, bytes, "upload");
  if (bytes == 0) return;
  activate();
  const auto* from = static_cast<const std::uint8_t*>(src);
  for (std::size_t done = 0; done < bytes;) {
    const std::size_t chunk = std::min(bytes - done, kStagingLimit);
    void* pinned = staging(chunk);
    std::memcpy(pinned, from + done, chunk);
    check(cudaMemcpyAsync(dev<std::uint8_t>(dst, static_cast<std::int64_t>(dst_offset + done)), pinned, chunk,
                          cudaMemcpyHostToDevice, stream_),
          "cudaMemcpyAsync(" + std::to_string(chunk) + " bytes, host to device)");
    check(cudaEventRecord(staging_free_, stream_), "cudaEventRecord(staging)");
    done += chunk;
  }
}

// Waits for every kernel before it: errors of earlier asynchronous work surface here.
void CudaBackend::download(const Buffer& src, std::size_t src_offset, void* dst, std::size_t bytes) {
  check_range(src, src_offset, bytes, "download");
  if (bytes == 0) return;
  activate();
  auto* to = static_cast<std::uint8_t*>(dst);
  for (std::size_t done = 0; done < bytes;) {
    const std::size_t chunk = std::min(bytes - done, kStagingLimit);
    void* pinned = staging(chunk);
    check(cudaMemcpyAsync(pinned, dev<std::uint8_t>(src, static_cast<std::int64_t>(src_offset + done)), chunk,
                          cudaMemcpyDeviceToHost, stream_),
          "cudaMemcpyAsync(" + std::to_string(chunk) + " bytes, device to host)");
    check(cudaStreamSynchronize(stream_), "cudaStreamSynchronize",
          "in download(); the failure may come from any kernel enqueued since the last synchronize()");
    std::memcpy(to + done, pinned, chunk);
    done += chunk;
  }
}

void CudaBackend::fill(Buffer& dst, std::size_t offset, std::size_t bytes, std::uint8_t value) {
  check_range(dst, offset, bytes, "fill");
  if (bytes == 0) return;
  activate();
  check(cudaMemsetAsync(dev<std::uint8_t>(dst, static_cast<std::int64_t>(offset)), value, bytes, stream_),
        "cudaMemsetAsync(" + std::to_string(bytes) + " bytes)");
}

void CudaBackend::synchronize() {
  activate();
  check(cudaStreamSynchronize(stream_), "cudaStreamSynchronize",
        "the failure may come from any kernel enqueued since the last synchronize()");
}

Buffer& CudaBackend::scratch(const std::string& name, std::size_t bytes) {
  auto& slot = scratch_[name];
  if (!slot || slot->size_bytes() < bytes) {
    slot.reset();  // cudaFree waits for the kernels that may still use the old buffer
    slot = allocate(bytes);
  }
  return *slot;
}

}  // namespace porta::cuda

namespace porta {

void register_cuda_backend(BackendRegistry& registry) {
  registry.add(
      "cuda",
      [] {
        BackendInfo info{"cuda", true, false, {}};
        std::string why;
        const auto devices = cuda::enumerate_devices(&why);
        info.available = !devices.empty();
        info.detail = devices.empty() ? "no CUDA device (" + why + ")"
                                      : cuda::list_devices(devices) +
                                            "; kernels built for CUDA architectures " + PORTA_CUDA_ARCHS;
        return info;
      },
      [](const BackendOptions& options) -> std::unique_ptr<Backend> {
        return std::make_unique<cuda::CudaBackend>(options);
      });
}

}  // namespace porta
