// Queues, memory and transfers of the OpenCL backend (opencl_backend.hpp): kQueues in-order
// command queues as the HAL's queues, kernel enqueueing with profiling events or through the
// submission thread (cl_submitter.hpp), pinned host buffers and their non-blocking transfers.
#include <cstring>
#include <memory>
#include <utility>
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
  static std::unique_ptr<HostBuffer> make(cl_context context, cl_command_queue queue, std::size_t bytes,
                                          std::shared_ptr<ClSubmitter> submitter) {
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
    return std::unique_ptr<HostBuffer>(
        new OpenClHostBuffer(mem, queue, static_cast<std::uint8_t*>(ptr), bytes, std::move(submitter)));
  }
  ~OpenClHostBuffer() override {
    // A transfer from or to this memory may still wait in the submission thread.
    if (submitter_) submitter_->drain_quietly();
    clEnqueueUnmapMemObject(queue_, mem_, data(), 0, nullptr, nullptr);
    clFinish(queue_);
    clReleaseMemObject(mem_);
    clReleaseCommandQueue(queue_);
  }

 private:
  OpenClHostBuffer(cl_mem mem, cl_command_queue queue, std::uint8_t* data, std::size_t bytes,
                   std::shared_ptr<ClSubmitter> submitter)
      : HostBuffer(data, bytes), mem_(mem), queue_(queue), submitter_(std::move(submitter)) {}
  cl_mem mem_;
  cl_command_queue queue_;  // retained: unmaps on it, even after the backend has gone
  std::shared_ptr<ClSubmitter> submitter_;  // null without a submission thread
};

/// A transfer or fill command.
ClCommand transfer(ClCommand::Kind kind, const char* name, cl_mem mem, std::size_t offset, std::size_t bytes,
                   void* host) {
  ClCommand command;
  command.kind = kind;
  command.name = name;
  command.mem = mem;
  command.offset = offset;
  command.bytes = bytes;
  command.host = host;
  return command;
}

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

OpenClBackend::Geometry OpenClBackend::geometry(const Range& range) const {
  Geometry g;
  if (range.global[0] == 0 || (range.dims == 2 && range.global[1] == 0)) return g;
  std::size_t global[2] = {range.global[0], range.global[1]};
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
  g.global[0] = global[0];
  g.global[1] = global[1];
  g.local[0] = r.local[0];
  g.local[1] = r.local[1] ? r.local[1] : 1;
  g.dims = static_cast<cl_uint>(r.dims);
  g.has_local = has_local;
  return g;
}

void OpenClBackend::enqueue(cl_kernel k, const char* kernel_name, const Range& range, Clock::time_point start) {
  const Geometry g = geometry(range);
  if (g.global[0] == 0) return;
  cl_event event = nullptr;
  if (const cl_int err = clEnqueueNDRangeKernel(queue(), k, g.dims, nullptr, g.global, g.has_local ? g.local : nullptr,
                                                0, nullptr, event_slot(event));
      err != CL_SUCCESS)
    check(err, "clEnqueueNDRangeKernel", kernel_name);
  note_command(kernel_name, event, start);
}

void OpenClBackend::enqueue_later(ClCommand&& command, const Range& range) {
  const Geometry g = geometry(range);
  if (g.global[0] == 0) return;
  command.kind = ClCommand::Kind::kernel;
  command.dims = g.dims;
  for (int d = 0; d < 2; ++d) {
    command.global[d] = g.global[d];
    command.local[d] = g.local[d];
  }
  command.has_local = g.has_local;
  push(std::move(command));
}

void OpenClBackend::push(ClCommand&& command) {
  command.queue = queue();
  submitter_->push(std::move(command));
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
  mark_used(other);
  if (submitter_) {
    ClCommand command;
    command.kind = ClCommand::Kind::wait_for;
    command.name = "queue_wait";
    command.other = queues_[static_cast<std::size_t>(other)];
    push(std::move(command));
    return;
  }
  const Clock::time_point start = profile_kernels_ ? Clock::now() : Clock::time_point{};
  cl_event marker = nullptr;
  check(clEnqueueMarkerWithWaitList(queues_[static_cast<std::size_t>(other)], 0, nullptr, &marker),
        "clEnqueueMarkerWithWaitList", "queue_wait(" + std::to_string(other) + ")");
  const cl_int err = clEnqueueBarrierWithWaitList(queue(), 1, &marker, nullptr);
  clReleaseEvent(marker);
  check(err, "clEnqueueBarrierWithWaitList", "queue_wait(" + std::to_string(other) + ")");
  note_command("(queue_wait)", nullptr, start);
}

void OpenClBackend::finish_queue(int queue) {
  check_queue_index(queue, "finish_queue");
  drain();
  check(clFinish(queues_[static_cast<std::size_t>(queue)]), "clFinish", "queue " + std::to_string(queue));
  unflushed_[static_cast<std::size_t>(queue)] = false;
  unfinished_[static_cast<std::size_t>(queue)] = false;
  read_timed_events(queue);
}

void OpenClBackend::finish_all() {
  drain();
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
    if (submitter_) {
      ClCommand command;
      command.kind = ClCommand::Kind::flush;
      command.name = "flush";
      command.queue = queues_[static_cast<std::size_t>(q)];
      submitter_->push(std::move(command));
      continue;
    }
    if (const cl_int err = clFlush(queues_[static_cast<std::size_t>(q)]); err != CL_SUCCESS)
      check(err, "clFlush", "queue " + std::to_string(q));
  }
}

// ---- Memory and transfers ------------------------------------------------------------------------

std::unique_ptr<Buffer> OpenClBackend::allocate(std::size_t bytes) {
  cl_int err = CL_SUCCESS;
  cl_mem m = clCreateBuffer(context_, CL_MEM_READ_WRITE, bytes > 0 ? bytes : 1, nullptr, &err);
  check(err, "clCreateBuffer", std::to_string(bytes) + " bytes");
  auto buffer = std::make_unique<OpenClBuffer>(m, bytes, submitter_);
  fill(*buffer, 0, bytes, 0);
  return buffer;
}

std::unique_ptr<HostBuffer> OpenClBackend::allocate_host(std::size_t bytes) {
  drain();  // the mapping waits on queue 0, after what the worker has for it
  return OpenClHostBuffer::make(context_, queues_[0], bytes, submitter_);
}

void OpenClBackend::upload(Buffer& dst, std::size_t dst_offset, const void* src, std::size_t bytes) {
  check_range(dst, dst_offset, bytes, "upload");
  if (bytes == 0) return;
  drain();  // in order behind the queue's earlier commands
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
  if (submitter_) {
    push(transfer(ClCommand::Kind::write, "upload_async", mem_of(dst), dst_offset, bytes,
                  const_cast<std::uint8_t*>(src.data()) + src_offset));
    return;
  }
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
  if (submitter_) {
    push(transfer(ClCommand::Kind::read, "download_async", mem_of(src), src_offset, bytes, dst.data() + dst_offset));
    return;
  }
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
  if (submitter_) {
    ClCommand command = transfer(ClCommand::Kind::fill, "fill", mem_of(dst), offset, bytes, nullptr);
    command.value = value;
    push(std::move(command));
    return;
  }
  check(clEnqueueFillBuffer(queue(), mem_of(dst), &value, 1, offset, bytes, 0, nullptr, nullptr),
        "clEnqueueFillBuffer");
}

Buffer& OpenClBackend::scratch(const std::string& name, std::size_t bytes) {
  auto& slot = scratch_[{current_, name}];
  if (!slot || slot->size_bytes() < bytes) slot = allocate(bytes);
  return *slot;
}

}  // namespace porta::opencl
