// The OpenCL backend's submission thread (cl_submitter.hpp).
#include "opencl/cl_submitter.hpp"

#include <chrono>
#include <cstring>
#include <utility>

#include "cpu/thread_name.hpp"
#include "opencl/cl_errors.hpp"

namespace porta::opencl {

namespace {

using Clock = std::chrono::steady_clock;

// How long the worker looks for the next command before it sleeps, and a drain for the worker
// before it sleeps: a frame's calls come microseconds apart, and a sleeping thread takes tens of
// microseconds to wake, about what a small frame costs on the device.
constexpr auto kWorkerSpin = std::chrono::microseconds(50);
constexpr auto kDrainSpin = std::chrono::microseconds(200);

inline void relax() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#elif defined(__aarch64__)
  asm volatile("yield");
#endif
}

}  // namespace

void ClCommand::add_arg(const void* value, std::size_t size) {
  const auto* bytes = static_cast<const unsigned char*>(value);
  arg_bytes.insert(arg_bytes.end(), bytes, bytes + size);
  arg_begin.push_back(static_cast<std::uint32_t>(arg_bytes.size()));
}

void execute(const ClCommand& c) {
  switch (c.kind) {
    case ClCommand::Kind::kernel: {
      for (std::size_t i = 0; i + 1 < c.arg_begin.size(); ++i) {
        const std::uint32_t begin = c.arg_begin[i], end = c.arg_begin[i + 1];
        if (const cl_int err = clSetKernelArg(c.kernel, static_cast<cl_uint>(i), end - begin, c.arg_bytes.data() + begin);
            err != CL_SUCCESS)
          check(err, "clSetKernelArg", std::string(c.name) + " argument " + std::to_string(i));
      }
      if (const cl_int err = clEnqueueNDRangeKernel(c.queue, c.kernel, c.dims, nullptr, c.global,
                                                    c.has_local ? c.local : nullptr, 0, nullptr, nullptr);
          err != CL_SUCCESS)
        check(err, "clEnqueueNDRangeKernel", c.name);
      return;
    }
    case ClCommand::Kind::write:
      check(clEnqueueWriteBuffer(c.queue, c.mem, CL_FALSE, c.offset, c.bytes, c.host, 0, nullptr, nullptr),
            "clEnqueueWriteBuffer", c.name);
      return;
    case ClCommand::Kind::read:
      check(clEnqueueReadBuffer(c.queue, c.mem, CL_FALSE, c.offset, c.bytes, c.host, 0, nullptr, nullptr),
            "clEnqueueReadBuffer", c.name);
      return;
    case ClCommand::Kind::fill:
      check(clEnqueueFillBuffer(c.queue, c.mem, &c.value, 1, c.offset, c.bytes, 0, nullptr, nullptr),
            "clEnqueueFillBuffer", c.name);
      return;
    case ClCommand::Kind::wait_for: {
      cl_event marker = nullptr;
      check(clEnqueueMarkerWithWaitList(c.other, 0, nullptr, &marker), "clEnqueueMarkerWithWaitList", c.name);
      const cl_int err = clEnqueueBarrierWithWaitList(c.queue, 1, &marker, nullptr);
      clReleaseEvent(marker);
      check(err, "clEnqueueBarrierWithWaitList", c.name);
      return;
    }
    case ClCommand::Kind::flush:
      check(clFlush(c.queue), "clFlush", c.name);
      return;
  }
}

ClSubmitter::ClSubmitter() : thread_([this] { run(); }) {}

ClSubmitter::~ClSubmitter() {
  drain_quietly();
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  work_cv_.notify_one();
  thread_.join();
}

void ClSubmitter::push(ClCommand&& command) {
  bool wake = false;
  {
    std::lock_guard lock(mutex_);
    pending_.push_back(std::move(command));
    pushed_.fetch_add(1, std::memory_order_release);
    wake = sleeping_;
  }
  if (wake) work_cv_.notify_one();
}

void ClSubmitter::run() {
  cpu::name_this_thread("porta-cl-submit");
  std::vector<ClCommand> batch;
  std::uint64_t taken = 0;
  for (;;) {
    const Clock::time_point until = Clock::now() + kWorkerSpin;
    while (pushed_.load(std::memory_order_acquire) == taken && Clock::now() < until) relax();
    {
      std::unique_lock lock(mutex_);
      if (pending_.empty() && !stopping_) {
        sleeping_ = true;
        work_cv_.wait(lock, [this] { return !pending_.empty() || stopping_; });
        sleeping_ = false;
      }
      if (pending_.empty()) return;  // stopping, and nothing left
      batch.swap(pending_);
    }
    taken += batch.size();
    for (const ClCommand& c : batch) {
      try {
        execute(c);
      } catch (...) {
        std::lock_guard lock(mutex_);
        if (!failure_) failure_ = std::current_exception();
      }
    }
    const std::uint64_t n = batch.size();
    batch.clear();
    {
      std::lock_guard lock(mutex_);
      done_.fetch_add(n, std::memory_order_release);
    }
    done_cv_.notify_all();
  }
}

void ClSubmitter::wait_done(std::uint64_t target) {
  const Clock::time_point until = Clock::now() + kDrainSpin;
  while (done_.load(std::memory_order_acquire) < target) {
    if (Clock::now() >= until) {
      std::unique_lock lock(mutex_);
      done_cv_.wait(lock, [&] { return done_.load(std::memory_order_acquire) >= target; });
      return;
    }
    relax();
  }
}

void ClSubmitter::drain() {
  wait_done(pushed_.load(std::memory_order_acquire));
  std::exception_ptr failure;
  {
    std::lock_guard lock(mutex_);
    failure = std::exchange(failure_, nullptr);
  }
  if (failure) std::rethrow_exception(failure);
}

void ClSubmitter::drain_quietly() noexcept {
  wait_done(pushed_.load(std::memory_order_acquire));
  std::lock_guard lock(mutex_);
  failure_ = nullptr;
}

}  // namespace porta::opencl
