// Queues, memory and transfers of the OpenCL backend (opencl_backend.hpp): kQueues in-order
// command queues as the HAL's queues, kernel enqueueing with profiling events, pinned host buffers
// and their non-blocking transfers.
#include <cstring>
#include <string>

#include "opencl/cl_errors.hpp"
#include "opencl/cl_types.hpp"
#include "opencl/opencl_backend.hpp"

namespace porta::opencl {

namespace {

void check_range(const Buffer& b, std::size_t offset, std::size_t bytes, const char* call) {
  if (offset > b.size_bytes() || bytes > b.size_bytes() - offset)
    throw BackendError(std::string("opencl: ") + call + ": range [" + std::to_string(offset) + ", +" +
                       std::to_string(bytes) + ") is outside the buffer of " + std::to_string(b.size_bytes()) +
                       " bytes");
}

/// Pinned host memory: a CL_MEM_ALLOC_HOST_PTR buffer mapped for its whole life (the driver's
/// page-locked memory, which its transfers copy from without staging).
class OpenClHostBuffer final : public HostBuffer {
 public:
  static std::unique_ptr<HostBuffer> make(cl_context context, cl_command_queue queue, std::size_t bytes) {
    cl_int err = CL_SUCCESS;
    const std::size_t size = bytes > 0 ? bytes : 1;
    cl_mem mem = clCreateBuffer(context, CL_MEM_READ_WRITE | CL_MEM_ALLOC_HOST_PTR, size, nullptr, &err);
    check(err, "clCreateBuffer", std::to_string(bytes) + " bytes of pinned host memory");
    void* ptr = clEnqueueMapBuffer(queue, mem, CL_TRUE, CL_MAP_READ | CL_MAP_WRITE, 0, size, 0, nullptr, nullptr, &err);
    if (err != CL_SUCCESS) {
      clReleaseMemObject(mem);
      check(err, "clEnqueueMapBuffer", std::to_string(bytes) + " bytes of pinned host memory");
    }
    std::memset(ptr, 0, size);
    clRetainCommandQueue(queue);
    return std::unique_ptr<HostBuffer>(new OpenClHostBuffer(mem, queue, static_cast<std::uint8_t*>(ptr), bytes));
  }
  ~OpenClHostBuffer() override {
    clEnqueueUnmapMemObject(queue_, mem_, data(), 0, nullptr, nullptr);
    clFinish(queue_);
    clReleaseMemObject(mem_);
    clReleaseCommandQueue(queue_);
  }

 private:
  OpenClHostBuffer(cl_mem mem, cl_command_queue queue, std::uint8_t* data, std::size_t bytes)
      : HostBuffer(data, bytes), mem_(mem), queue_(queue) {}
  cl_mem mem_;
  cl_command_queue queue_;  // retained: unmaps on it, even after the backend has gone
};

}  // namespace

// ---- Kernels -------------------------------------------------------------------------------------

Range Range::tiles(std::size_t tiles) {
  return {{tiles * kTileW, kTileH}, {kTileW, kTileH}, 2};
}

void OpenClBackend::note_command(const char* name, cl_event event, Clock::time_point start) {
  if (!profile_kernels_) return;
  profile_.add_host(name, std::chrono::duration<double, std::milli>(Clock::now() - start).count(), event == nullptr);
  if (event != nullptr) timed_.push_back({current_, name, event});
}

void OpenClBackend::enqueue(cl_kernel k, const char* kernel_name, const Range& range, Clock::time_point start) {
  std::size_t global[2] = {range.global[0], range.global[1]};
  if (global[0] == 0 || (range.dims == 2 && global[1] == 0)) return;
  Range r = range;
  if (r.local[0] == 0 && work_groups_) {
    // GPUs: a work-group size of our choosing, the global size rounded up to it (every kernel
    // tests its ids against its real extent). Left to the driver, a size that divides the global
    // size exactly can be a handful of work-items (a prime number of cells: groups of 1).
    r.local[0] = r.dims == 2 ? kTileW : 64;
    r.local[1] = r.dims == 2 ? kTileH : 0;
  }
  const bool has_local = r.local[0] != 0;
  if (has_local) {
    for (int d = 0; d < r.dims; ++d) {
      const std::size_t l = r.local[d] ? r.local[d] : 1;
      global[d] = (global[d] + l - 1) / l * l;
    }
  }
  std::size_t local[2] = {r.local[0], r.local[1] ? r.local[1] : 1};
  cl_event event = nullptr;
  if (const cl_int err = clEnqueueNDRangeKernel(queue(), k, static_cast<cl_uint>(r.dims), nullptr, global,
                                                has_local ? local : nullptr, 0, nullptr, event_slot(event));
      err != CL_SUCCESS)
    check(err, "clEnqueueNDRangeKernel", kernel_name);
  note_command(kernel_name, event, start);
}

void OpenClBackend::read_timed_events(int queue) {
  std::vector<TimedDispatch> keep;
  std::string failure;
  for (TimedDispatch& t : timed_) {
    if (queue >= 0 && t.queue != queue) {
      keep.push_back(std::move(t));
      continue;
    }
    cl_ulong start = 0, end = 0;
    const cl_int a = clGetEventProfilingInfo(t.event, CL_PROFILING_COMMAND_START, sizeof(start), &start, nullptr);
    const cl_int b = clGetEventProfilingInfo(t.event, CL_PROFILING_COMMAND_END, sizeof(end), &end, nullptr);
    clReleaseEvent(t.event);
    if (a != CL_SUCCESS || b != CL_SUCCESS) {
      if (failure.empty()) failure = t.kernel;
      continue;
    }
    profile_.add(t.kernel, end >= start ? static_cast<double>(end - start) * 1e-6 : 0.0);
  }
  timed_ = std::move(keep);
  if (!failure.empty()) check(CL_PROFILING_INFO_NOT_AVAILABLE, "clGetEventProfilingInfo", failure);
}

std::vector<KernelTime> OpenClBackend::kernel_times(bool reset) {
  synchronize();
  return profile_.take(reset);
}

// ---- Queues --------------------------------------------------------------------------------------

void OpenClBackend::use_queue(int queue) {
  check_queue_index(queue, "use_queue");
  current_ = queue;
}

void OpenClBackend::queue_wait(int other) {
  check_queue_index(other, "queue_wait");
  if (other == current_) return;  // in order already
  const Clock::time_point start = profile_kernels_ ? Clock::now() : Clock::time_point{};
  cl_event marker = nullptr;
  mark_used(other);
  check(clEnqueueMarkerWithWaitList(queues_[static_cast<std::size_t>(other)], 0, nullptr, &marker),
        "clEnqueueMarkerWithWaitList", "queue_wait(" + std::to_string(other) + ")");
  const cl_int err = clEnqueueBarrierWithWaitList(queue(), 1, &marker, nullptr);
  clReleaseEvent(marker);
  check(err, "clEnqueueBarrierWithWaitList", "queue_wait(" + std::to_string(other) + ")");
  note_command("(queue_wait)", nullptr, start);
}

void OpenClBackend::finish_queue(int queue) {
  check_queue_index(queue, "finish_queue");
  check(clFinish(queues_[static_cast<std::size_t>(queue)]), "clFinish", "queue " + std::to_string(queue));
  unflushed_[static_cast<std::size_t>(queue)] = false;
  unfinished_[static_cast<std::size_t>(queue)] = false;
  read_timed_events(queue);
}

void OpenClBackend::finish_all() {
  for (int q = 0; q < queue_count_; ++q) {
    if (!unfinished_[static_cast<std::size_t>(q)]) continue;
    check(clFinish(queues_[static_cast<std::size_t>(q)]), "clFinish", "queue " + std::to_string(q));
    unflushed_[static_cast<std::size_t>(q)] = false;
    unfinished_[static_cast<std::size_t>(q)] = false;
  }
}

void OpenClBackend::synchronize() {
  finish_all();
  read_timed_events(-1);  // complete now; their events are not kept past a synchronize
}

void OpenClBackend::flush() {
  for (int q = 0; q < queue_count_; ++q) {
    if (!unflushed_[static_cast<std::size_t>(q)]) continue;
    unflushed_[static_cast<std::size_t>(q)] = false;
    if (const cl_int err = clFlush(queues_[static_cast<std::size_t>(q)]); err != CL_SUCCESS)
      check(err, "clFlush", "queue " + std::to_string(q));
  }
}

// ---- Memory and transfers ------------------------------------------------------------------------

std::unique_ptr<Buffer> OpenClBackend::allocate(std::size_t bytes) {
  cl_int err = CL_SUCCESS;
  cl_mem m = clCreateBuffer(context_, CL_MEM_READ_WRITE, bytes > 0 ? bytes : 1, nullptr, &err);
  check(err, "clCreateBuffer", std::to_string(bytes) + " bytes");
  auto buffer = std::make_unique<OpenClBuffer>(m, bytes);
  fill(*buffer, 0, bytes, 0);
  return buffer;
}

std::unique_ptr<HostBuffer> OpenClBackend::allocate_host(std::size_t bytes) {
  return OpenClHostBuffer::make(context_, queues_[0], bytes);
}

void OpenClBackend::upload(Buffer& dst, std::size_t dst_offset, const void* src, std::size_t bytes) {
  check_range(dst, dst_offset, bytes, "upload");
  if (bytes == 0) return;
  check(clEnqueueWriteBuffer(queue(), mem_of(dst), CL_TRUE, dst_offset, bytes, src, 0, nullptr, nullptr),
        "clEnqueueWriteBuffer");
}

void OpenClBackend::download(const Buffer& src, std::size_t src_offset, void* dst, std::size_t bytes) {
  check_range(src, src_offset, bytes, "download");
  if (bytes == 0) return;
  finish_all();  // a download sees the work of every queue
  check(clEnqueueReadBuffer(queue(), mem_of(src), CL_TRUE, src_offset, bytes, dst, 0, nullptr, nullptr),
        "clEnqueueReadBuffer");
}

void OpenClBackend::upload_async(Buffer& dst, std::size_t dst_offset, const HostBuffer& src, std::size_t src_offset,
                                 std::size_t bytes) {
  check_host_range(src, src_offset, bytes, "opencl", "upload_async");
  check_range(dst, dst_offset, bytes, "upload_async");
  if (bytes == 0) return;
  const Clock::time_point start = profile_kernels_ ? Clock::now() : Clock::time_point{};
  cl_event event = nullptr;
  check(clEnqueueWriteBuffer(queue(), mem_of(dst), CL_FALSE, dst_offset, bytes, src.data() + src_offset, 0, nullptr,
                             event_slot(event)),
        "clEnqueueWriteBuffer", "upload_async");
  note_command("(upload_async)", event, start);
}

void OpenClBackend::download_async(const Buffer& src, std::size_t src_offset, HostBuffer& dst, std::size_t dst_offset,
                                   std::size_t bytes) {
  check_host_range(dst, dst_offset, bytes, "opencl", "download_async");
  check_range(src, src_offset, bytes, "download_async");
  if (bytes == 0) return;
  const Clock::time_point start = profile_kernels_ ? Clock::now() : Clock::time_point{};
  cl_event event = nullptr;
  check(clEnqueueReadBuffer(queue(), mem_of(src), CL_FALSE, src_offset, bytes, dst.data() + dst_offset, 0, nullptr,
                            event_slot(event)),
        "clEnqueueReadBuffer", "download_async");
  note_command("(download_async)", event, start);
}

void OpenClBackend::fill(Buffer& dst, std::size_t offset, std::size_t bytes, std::uint8_t value) {
  check_range(dst, offset, bytes, "fill");
  if (bytes == 0) return;
  check(clEnqueueFillBuffer(queue(), mem_of(dst), &value, 1, offset, bytes, 0, nullptr, nullptr),
        "clEnqueueFillBuffer");
}

Buffer& OpenClBackend::scratch(const std::string& name, std::size_t bytes) {
  auto& slot = scratch_[{current_, name}];
  if (!slot || slot->size_bytes() < bytes) slot = allocate(bytes);
  return *slot;
}

}  // namespace porta::opencl
