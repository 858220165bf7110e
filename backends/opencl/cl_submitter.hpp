// The OpenCL backend's submission thread: the HAL calls that only enqueue (kernel launches, the
// non-blocking transfers and fills, the queues' waits and flushes) become commands that one worker
// thread hands to the driver, in the order they were made. NVIDIA's OpenCL spends ~5 us of the
// host's time in every enqueue, ~40 of them per stereo frame: on the worker they overlap the
// calling thread's own work (copying the next images, the next frame's calls) instead of adding
// to it. The calls that wait (finish, blocking transfers, mapping) drain the worker first, and an
// enqueue that failed there is thrown by the next of them (ClSubmitter::drain). A buffer (device
// or pinned host memory) drains the worker before it is released, so no command the worker still
// holds names a released buffer (retaining each command's buffers instead costs two driver calls
// per argument).
#pragma once

#include <CL/cl.h>

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace porta::opencl {

/// One enqueue, as the worker makes it.
struct ClCommand {
  enum class Kind : std::uint8_t { kernel, write, read, fill, wait_for, flush };
  Kind kind = Kind::kernel;
  cl_command_queue queue = nullptr;
  const char* name = "";  ///< the kernel's or the call's, for error messages (a string literal)
  // kernel
  cl_kernel kernel = nullptr;
  cl_uint dims = 1;
  std::size_t global[2] = {1, 1};
  std::size_t local[2] = {1, 1};
  bool has_local = false;
  /// Argument i: its bytes are arg_bytes[arg_begin[i], arg_begin[i + 1]).
  std::vector<std::uint32_t> arg_begin{0};
  std::vector<unsigned char> arg_bytes;
  // write, read, fill: the buffer, its range and the host side
  cl_mem mem = nullptr;
  std::size_t offset = 0, bytes = 0;
  void* host = nullptr;
  std::uint8_t value = 0;
  // wait_for: the queue `queue` waits for
  cl_command_queue other = nullptr;

  /// Appends an argument of `size` bytes.
  void add_arg(const void* value, std::size_t size);
};

class ClSubmitter {
 public:
  ClSubmitter();
  /// Drains (failures dropped) and stops the worker.
  ~ClSubmitter();
  ClSubmitter(const ClSubmitter&) = delete;
  ClSubmitter& operator=(const ClSubmitter&) = delete;

  /// Queues `command` behind the ones before it.
  void push(ClCommand&& command);
  /// Returns when every command pushed so far has been handed to the driver; throws the first
  /// failure since the last drain (a BackendError naming the call), after which the rest ran on.
  void drain();
  /// drain() for destructors: waits, drops any failure.
  void drain_quietly() noexcept;
  /// Commands pushed so far (for tests).
  std::uint64_t pushed() const { return pushed_.load(std::memory_order_acquire); }

 private:
  void run();
  void wait_done(std::uint64_t target);

  std::mutex mutex_;
  std::condition_variable work_cv_, done_cv_;
  std::vector<ClCommand> pending_;
  std::atomic<std::uint64_t> pushed_{0}, done_{0};
  bool stopping_ = false;
  bool sleeping_ = false;
  std::exception_ptr failure_;
  std::thread thread_;
};

/// Enqueues `command` on the calling thread (what the worker does with each).
void execute(const ClCommand& command);

}  // namespace porta::opencl
