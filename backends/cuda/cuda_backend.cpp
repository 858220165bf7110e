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
/// Pinned upload arena of a queue: at least kArenaMin, doubled when a segment needs more, at most
/// kArenaMax unless one chunk needs more (a chunk is at most kStagingLimit).
constexpr std::size_t kArenaMin = std::size_t{1} << 20;
constexpr std::size_t kArenaMax = std::size_t{32} << 20;
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

std::string env_text(const char* name) {
  const char* env = std::getenv(name);
  return env == nullptr ? std::string() : std::string(env);
}

CullVariant read_cull_variant() {
  const std::string text = env_text("PORTA_CUDA_CULL");
  return text.empty() ? CullVariant::kMlptTewa : parse_cull_variant(text);
}

GraphMode read_graph_mode() {
  const std::string text = lower(env_text("PORTA_CUDA_GRAPHS"));
  if (text.empty() || text == "1" || text == "on") return GraphMode::kRepeat;
  if (text == "0" || text == "off") return GraphMode::kOff;
  if (text == "eager" || text == "2") return GraphMode::kEager;
  throw BackendError("cuda: PORTA_CUDA_GRAPHS='" + text +
                     "' is not one of 0 (launch every kernel directly), 1 (default: replay repeated launch "
                     "sequences as CUDA graphs), eager (capture every sequence at once)");
}

bool read_streams_enabled() {
  const std::string text = lower(env_text("PORTA_CUDA_STREAMS"));
  if (text.empty() || text == "1" || text == "on") return true;
  if (text == "0" || text == "off") return false;
  throw BackendError("cuda: PORTA_CUDA_STREAMS='" + text +
                     "' is not 0 (one stream) or 1 (default: one stream per queue)");
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
  // Operations still pending on the backend may use this memory: submit them and let the device
  // finish before the memory goes (a destructor cannot throw; the backend keeps any error).
  if (link_ && link_->backend) link_->backend->quiesce_before_free();
  // Free on the device that owns the memory, and leave the thread's current device as it was.
  int current = -1;
  const bool switch_device = cudaGetDevice(&current) == cudaSuccess && current != device_;
  if (switch_device) static_cast<void>(cudaSetDevice(device_));
  static_cast<void>(cudaFree(ptr_));  // a destructor cannot throw; a failure here leaks at worst
  if (switch_device) static_cast<void>(cudaSetDevice(current));
}

CudaHostBuffer::~CudaHostBuffer() {
  if (data() == nullptr) return;
  // Copies to or from this memory may be pending or running, and cached graphs name it.
  if (link_ && link_->backend) link_->backend->quiesce_before_free();
  int current = -1;
  const bool switch_device = cudaGetDevice(&current) == cudaSuccess && current != device_;
  if (switch_device) static_cast<void>(cudaSetDevice(device_));
  static_cast<void>(cudaFreeHost(data()));  // a destructor cannot throw; a failure here leaks at worst
  if (switch_device) static_cast<void>(cudaSetDevice(current));
}

const char* cull_variant_name(CullVariant v) {
  switch (v) {
    case CullVariant::kMlptTewa: return "mlpt_tewa";
    case CullVariant::kMlptBlock: return "mlpt_block";
    case CullVariant::kLog2Block: return "log2_block";
  }
  return "?";
}

CullVariant parse_cull_variant(const std::string& text) {
  for (CullVariant v : {CullVariant::kMlptTewa, CullVariant::kMlptBlock, CullVariant::kLog2Block})
    if (lower(text) == cull_variant_name(v)) return v;
  throw BackendError("cuda: culling variant '" + text +
                     "' (PORTA_CUDA_CULL) is not one of mlpt_tewa (default), mlpt_block, log2_block");
}

cudaError_t op_copy_h2d(std::uint8_t* dst, const std::uint8_t* src, std::size_t bytes, cudaStream_t stream) {
  return cudaMemcpyAsync(dst, src, bytes, cudaMemcpyHostToDevice, stream);
}
cudaError_t op_copy_d2h(std::uint8_t* dst, const std::uint8_t* src, std::size_t bytes, cudaStream_t stream) {
  return cudaMemcpyAsync(dst, src, bytes, cudaMemcpyDeviceToHost, stream);
}
cudaError_t op_copy_d2d(std::uint8_t* dst, const std::uint8_t* src, std::size_t bytes, cudaStream_t stream) {
  return cudaMemcpyAsync(dst, src, bytes, cudaMemcpyDeviceToDevice, stream);
}
cudaError_t op_fill(std::uint8_t* dst, int value, std::size_t bytes, cudaStream_t stream) {
  return cudaMemsetAsync(dst, value, bytes, stream);
}

CudaBackend::CudaBackend(const BackendOptions& options)
    : device_(select_device(options)),
      mlpt_nmax_(read_mlpt_nmax()),
      cull_variant_(read_cull_variant()),
      graph_mode_(read_graph_mode()),
      streams_enabled_(read_streams_enabled()),
      link_(std::make_shared<BackendLink>()) {
  check(cudaSetDevice(device_.index), "cudaSetDevice(" + std::to_string(device_.index) + ")",
        device_.label());
  if (const cudaError_t e = probe_kernel_image(); e != cudaSuccess) {
    static_cast<void>(cudaGetLastError());
    throw BackendError("cuda: " + device_.label() +
                       " cannot run this build's kernels (built for CUDA architectures " + PORTA_CUDA_ARCHS +
                       "; reconfigure with -DCMAKE_CUDA_ARCHITECTURES=" + std::to_string(device_.major) +
                       std::to_string(device_.minor) + "): " + error_text(e));
  }
  try {
    create_resources();
  } catch (...) {
    release_resources();
    throw;
  }
  link_->backend = this;
}

void CudaBackend::create_resources() {
  for (Queue& q : queues_) {
    check(cudaStreamCreateWithFlags(&q.stream, cudaStreamNonBlocking), "cudaStreamCreateWithFlags",
          device_.label());
    for (cudaEvent_t* e : {&q.done, &q.arena_free})
      check(cudaEventCreateWithFlags(e, cudaEventDisableTiming), "cudaEventCreateWithFlags", device_.label());
  }
}

void CudaBackend::release_resources() noexcept {
  for (Queue& q : queues_) {
    q.pending.clear();
    q.signature.clear();
    if (q.stream) static_cast<void>(cudaStreamSynchronize(q.stream));
  }
  for (CachedGraph& g : graphs_) static_cast<void>(cudaGraphExecDestroy(g.exec));
  graphs_.clear();
  for (Queue& q : queues_) {
    q.scratch.clear();
    if (q.arena) static_cast<void>(cudaFreeHost(q.arena));
    if (q.readback) static_cast<void>(cudaFreeHost(q.readback));
    for (cudaEvent_t e : {q.done, q.arena_free})
      if (e) static_cast<void>(cudaEventDestroy(e));
    if (q.stream) static_cast<void>(cudaStreamDestroy(q.stream));
    q = Queue{};
  }
}

CudaBackend::~CudaBackend() {
  // Destructors cannot throw: errors here are ignored (the memory goes with the process at worst).
  static_cast<void>(cudaSetDevice(device_.index));
  link_->backend = nullptr;  // buffers that outlive the backend free their memory plainly
  // Work recorded but never submitted is submitted now, as it would have been without deferral.
  try {
    flush_all();
  } catch (...) {
  }
  release_resources();
}

void CudaBackend::activate() const {
  check(cudaSetDevice(device_.index), "cudaSetDevice(" + std::to_string(device_.index) + ")",
        device_.label());
}

void CudaBackend::throw_deferred_error() {
  if (deferred_error_.empty()) return;
  std::string message;
  message.swap(deferred_error_);
  throw BackendError(message);
}

void CudaBackend::sync_queue(Queue& q, const char* where) {
  check(cudaStreamSynchronize(q.stream), "cudaStreamSynchronize",
        std::string(where) + "; the failure may come from any kernel enqueued since the last synchronize()");
  q.arena_busy = false;  // everything the queue was given has run
  q.may_run = false;
}

void CudaBackend::quiesce_before_free() noexcept {
  try {
    activate();
    flush_all();
    for (Queue& q : queues_) sync_queue(q, "before freeing a buffer");
  } catch (const std::exception& e) {
    if (deferred_error_.empty()) deferred_error_ = e.what();
  }
  drop_graphs();
}

// A graph names device and pinned addresses; once memory is freed, a new allocation may get the
// same address, and a replay would then match the key but use nodes made for the old allocation
// (seen on an H100: cudaGraphLaunch failing with cudaErrorInvalidValue, or a crash in the driver).
// So every free empties the cache. The Frontend frees nothing between frames, so its graphs stay.
void CudaBackend::drop_graphs() noexcept {
  for (CachedGraph& g : graphs_) static_cast<void>(cudaGraphExecDestroy(g.exec));  // freed when done
  if (!graphs_.empty()) ++stats_.cache_drops;
  graphs_.clear();
}

std::unique_ptr<Buffer> CudaBackend::allocate(std::size_t bytes) {
  activate();
  void* ptr = nullptr;
  const std::size_t n = bytes > 0 ? bytes : 1;
  check(cudaMalloc(&ptr, n), "cudaMalloc(" + std::to_string(bytes) + " bytes)");
  auto buffer = std::make_unique<CudaBuffer>(static_cast<std::uint8_t*>(ptr), bytes, device_.index, link_);
  // Zero-filled before any queue can use it: the fill is waited for here (allocation is rare: the
  // Frontend and the grow-only buffers allocate at set-up), so no queue needs to wait for another.
  Queue& q = queues_[current_];
  check(cudaMemsetAsync(ptr, 0, n, q.stream), "cudaMemsetAsync(" + std::to_string(n) + " bytes, zero-fill)");
  check(cudaStreamSynchronize(q.stream), "cudaStreamSynchronize", "after the zero-fill of a new buffer");
  return buffer;
}

std::uint8_t* CudaBackend::arena_take(std::size_t bytes) {
  Queue& q = queues_[current_];
  constexpr std::size_t kAlign = 256;
  std::size_t at = (q.arena_used + kAlign - 1) / kAlign * kAlign;
  if (at + bytes > q.arena_bytes) {
    // Full: submit what uses the arena so far, wait until it has been read, grow if needed.
    flush(current_);
    at = 0;
    if (bytes > q.arena_bytes) {
      if (q.arena_busy) sync_queue(q, "before growing the upload staging");
      drop_graphs();  // they may name the old staging memory
      if (q.arena) {
        std::uint8_t* old = q.arena;
        q.arena = nullptr;
        q.arena_bytes = 0;
        check(cudaFreeHost(old), "cudaFreeHost(upload staging)");
      }
      const std::size_t want = std::max(bytes, std::min(std::max(kArenaMin, 2 * bytes), kArenaMax));
      void* p = nullptr;
      check(cudaHostAlloc(&p, want, cudaHostAllocDefault), "cudaHostAlloc(" + std::to_string(want) + " bytes)");
      q.arena = static_cast<std::uint8_t*>(p);
      q.arena_bytes = want;
    }
  }
  if (at == 0 && q.arena_busy) {
    // A new segment starts at offset 0: the last submitted one may still be copying from there.
    check(cudaEventSynchronize(q.arena_free), "cudaEventSynchronize(upload staging)");
    q.arena_busy = false;
  }
  q.arena_used = at + bytes;
  return q.arena + at;
}

std::uint8_t* CudaBackend::readback(Queue& q, std::size_t bytes) {
  if (bytes > q.readback_bytes) {
    if (q.readback) {
      std::uint8_t* old = q.readback;
      q.readback = nullptr;
      q.readback_bytes = 0;
      check(cudaFreeHost(old), "cudaFreeHost(download staging)");
    }
    const std::size_t want = std::max(bytes, std::size_t{64} << 10);
    void* p = nullptr;
    check(cudaHostAlloc(&p, want, cudaHostAllocDefault), "cudaHostAlloc(" + std::to_string(want) + " bytes)");
    q.readback = static_cast<std::uint8_t*>(p);
    q.readback_bytes = want;
  }
  return q.readback;
}

// The upload returns once the source has been copied to pinned memory; the copy to the device
// runs on the current queue, in order with its kernels.
void CudaBackend::upload(Buffer& dst, std::size_t dst_offset, const void* src, std::size_t bytes) {
  check_range(dst, dst_offset, bytes, "upload");
  if (bytes == 0) return;
  activate();
  const auto* from = static_cast<const std::uint8_t*>(src);
  for (std::size_t done = 0; done < bytes;) {
    const std::size_t chunk = std::min(bytes - done, kStagingLimit);
    std::uint8_t* pinned = arena_take(chunk);
    std::memcpy(pinned, from + done, chunk);
    enqueue<&op_copy_h2d>("upload (host to device copy)",
                          dev<std::uint8_t>(dst, static_cast<std::int64_t>(dst_offset + done)),
                          static_cast<const std::uint8_t*>(pinned), chunk);
    done += chunk;
  }
}

// Waits for every operation before it on the current queue: errors of earlier asynchronous work
// surface here.
void CudaBackend::download(const Buffer& src, std::size_t src_offset, void* dst, std::size_t bytes) {
  check_range(src, src_offset, bytes, "download");
  throw_deferred_error();
  if (bytes == 0) return;
  activate();
  flush(current_);
  Queue& q = queues_[current_];
  auto* to = static_cast<std::uint8_t*>(dst);
  for (std::size_t done = 0; done < bytes;) {
    const std::size_t chunk = std::min(bytes - done, kStagingLimit);
    std::uint8_t* pinned = readback(q, chunk);
    check(cudaMemcpyAsync(pinned, dev<std::uint8_t>(src, static_cast<std::int64_t>(src_offset + done)), chunk,
                          cudaMemcpyDeviceToHost, q.stream),
          "cudaMemcpyAsync(" + std::to_string(chunk) + " bytes, device to host)");
    sync_queue(q, "in download()");
    std::memcpy(to + done, pinned, chunk);
    done += chunk;
  }
}

void CudaBackend::fill(Buffer& dst, std::size_t offset, std::size_t bytes, std::uint8_t value) {
  check_range(dst, offset, bytes, "fill");
  if (bytes == 0) return;
  activate();
  enqueue<&op_fill>("fill (cudaMemsetAsync)", dev<std::uint8_t>(dst, static_cast<std::int64_t>(offset)),
                    static_cast<int>(value), bytes);
}

void CudaBackend::synchronize() {
  throw_deferred_error();
  activate();
  flush_all();
  // Only queues given work since their last wait: a Frontend uses a few of the 16, and stage
  // profiling synchronizes after every stage.
  for (Queue& q : queues_)
    if (q.may_run) sync_queue(q, "in synchronize()");
}

namespace {

// Queue numbers are checked against all kMaxQueues even with streams off (queue_count() 1), where
// every queue is stream 0: a Frontend built before set_streams_enabled(false) keeps working.
void check_cuda_queue(int queue, const char* call) {
  if (queue < 0 || queue >= CudaBackend::kMaxQueues)
    throw BackendError(std::string("cuda: ") + call + "(" + std::to_string(queue) + "): queues are 0 to " +
                       std::to_string(CudaBackend::kMaxQueues - 1));
}

}  // namespace

void CudaBackend::use_queue(int queue) {
  check_cuda_queue(queue, "use_queue");
  if (!streams_enabled_ || queue == current_) return;
  activate();
  flush(current_);  // the queue being left starts running while the host records the next one
  current_ = queue;
}

void CudaBackend::queue_wait(int other) {
  check_cuda_queue(other, "queue_wait");
  if (!streams_enabled_ || other == current_) return;
  activate();
  Queue& o = queues_[static_cast<std::size_t>(other)];
  flush(other);
  flush(current_);  // keeps the order: the wait follows what the current queue was given
  check(cudaEventRecord(o.done, o.stream), "cudaEventRecord(queue_wait)");
  check(cudaStreamWaitEvent(queues_[static_cast<std::size_t>(current_)].stream, o.done, 0),
        "cudaStreamWaitEvent(queue_wait)");
  ++stats_.queue_waits;
}

void CudaBackend::finish_queue(int queue) {
  check_cuda_queue(queue, "finish_queue");
  throw_deferred_error();
  activate();
  const int q = streams_enabled_ ? queue : 0;
  flush(q);
  sync_queue(queues_[static_cast<std::size_t>(q)], "in finish_queue()");
}

std::unique_ptr<HostBuffer> CudaBackend::allocate_host(std::size_t bytes) {
  activate();
  void* p = nullptr;
  const std::size_t n = bytes > 0 ? bytes : 1;
  check(cudaHostAlloc(&p, n, cudaHostAllocDefault), "cudaHostAlloc(" + std::to_string(bytes) + " bytes)");
  std::memset(p, 0, n);
  return std::make_unique<CudaHostBuffer>(static_cast<std::uint8_t*>(p), bytes, device_.index, link_);
}

namespace {

const CudaHostBuffer& own_host_buffer(const HostBuffer& b, const BackendLink* link, const char* call) {
  const auto* pinned = dynamic_cast<const CudaHostBuffer*>(&b);
  if (pinned == nullptr || !pinned->made_by(link))
    throw BackendError(std::string("cuda: ") + call +
                       ": the host buffer was not made by this backend's allocate_host() (asynchronous "
                       "copies need its page-locked memory)");
  return *pinned;
}

}  // namespace

void CudaBackend::upload_async(Buffer& dst, std::size_t dst_offset, const HostBuffer& src, std::size_t src_offset,
                               std::size_t bytes) {
  check_range(dst, dst_offset, bytes, "upload_async");
  check_host_range(src, src_offset, bytes, "cuda", "upload_async");
  const CudaHostBuffer& pinned = own_host_buffer(src, link_.get(), "upload_async");
  if (bytes == 0) return;
  activate();
  enqueue<&op_copy_h2d>("upload_async (host to device copy)",
                        dev<std::uint8_t>(dst, static_cast<std::int64_t>(dst_offset)),
                        static_cast<const std::uint8_t*>(pinned.data() + src_offset), bytes);
}

void CudaBackend::download_async(const Buffer& src, std::size_t src_offset, HostBuffer& dst, std::size_t dst_offset,
                                 std::size_t bytes) {
  check_range(src, src_offset, bytes, "download_async");
  check_host_range(dst, dst_offset, bytes, "cuda", "download_async");
  own_host_buffer(dst, link_.get(), "download_async");
  if (bytes == 0) return;
  activate();
  enqueue<&op_copy_d2h>("download_async (device to host copy)", dst.data() + dst_offset,
                        dev<std::uint8_t>(src, static_cast<std::int64_t>(src_offset)), bytes);
}

void CudaBackend::set_graph_mode(GraphMode mode) {
  activate();
  flush_all();
  graph_mode_ = mode;
}

void CudaBackend::set_streams_enabled(bool on) {
  synchronize();
  streams_enabled_ = on;
  if (!on) current_ = 0;
}

Buffer& CudaBackend::scratch(const std::string& name, std::size_t bytes) {
  Queue& q = queues_[current_];
  auto& slot = q.scratch[name];
  if (!slot || slot->size_bytes() < bytes) {
    if (slot) {
      // Pending and running operations of this queue may still use the old memory.
      flush(current_);
      sync_queue(q, "before growing scratch memory");
      slot.reset();
    }
    slot = allocate(bytes);
  }
  return *slot;
}

void CudaBackend::flush_all() {
  for (int q = 0; q < kMaxQueues; ++q) flush(q);
}

void CudaBackend::run_direct(Queue& q, const std::vector<Op>& ops) {
  for (const Op& op : ops) {
    const cudaError_t e = op.run(q.stream);
    if (e != cudaSuccess) check(e, std::string(op.name) + " launch");
  }
}

namespace {

// A 64-bit hash of a signature (a multiple of 8 bytes): for lookup only, equality is checked on
// the bytes.
std::uint64_t hash_signature(const std::vector<std::uint8_t>& sig) {
  std::uint64_t h = 0x9E3779B97F4A7C15ull ^ sig.size();
  for (std::size_t i = 0; i + 8 <= sig.size(); i += 8) {
    std::uint64_t w = 0;
    std::memcpy(&w, sig.data() + i, 8);
    h ^= w;
    h *= 0xFF51AFD7ED558CCDull;
    h ^= h >> 29;
  }
  return h;
}

}  // namespace

bool CudaBackend::capture_and_launch(Queue& q, const std::vector<Op>& ops, std::vector<std::uint8_t>&& sig,
                                     std::uint64_t hash) {
  auto give_up = [&] {
    static_cast<void>(cudaGetLastError());
    uncapturable_.insert(hash);
    ++stats_.capture_failures;
    return false;
  };
  if (cudaStreamBeginCapture(q.stream, cudaStreamCaptureModeThreadLocal) != cudaSuccess) return give_up();
  cudaError_t launch_status = cudaSuccess;
  for (const Op& op : ops) {
    launch_status = op.run(q.stream);
    if (launch_status != cudaSuccess) break;
  }
  cudaGraph_t graph = nullptr;
  const cudaError_t end_status = cudaStreamEndCapture(q.stream, &graph);
  if (launch_status != cudaSuccess || end_status != cudaSuccess || graph == nullptr) {
    if (graph) static_cast<void>(cudaGraphDestroy(graph));
    return give_up();  // launched directly by the caller, which reports a genuine launch error
  }
  cudaGraphExec_t exec = nullptr;
  const cudaError_t inst_status = cudaGraphInstantiateWithFlags(&exec, graph, 0);
  static_cast<void>(cudaGraphDestroy(graph));
  if (inst_status != cudaSuccess) return give_up();
  if (const cudaError_t e = cudaGraphLaunch(exec, q.stream); e != cudaSuccess) {
    static_cast<void>(cudaGraphExecDestroy(exec));
    check(e, "cudaGraphLaunch", "a newly captured segment");
  }
  ++stats_.graph_captures;
  if (graphs_.size() >= kMaxGraphs) {
    // The least recently used one goes; an executable graph still running is freed when it ends.
    auto oldest = std::min_element(graphs_.begin(), graphs_.end(), [](const CachedGraph& a, const CachedGraph& b) {
      return a.last_use < b.last_use;
    });
    static_cast<void>(cudaGraphExecDestroy(oldest->exec));
    graphs_.erase(oldest);
  }
  graphs_.push_back(CachedGraph{hash, std::move(sig), exec, ++graph_clock_});
  return true;
}

void CudaBackend::flush(int index) {
  Queue& q = queues_[static_cast<std::size_t>(index)];
  if (q.pending.empty()) return;
  // Take the segment first: the queue is clean whatever happens below.
  std::vector<Op> ops;
  ops.swap(q.pending);
  std::vector<std::uint8_t> sig;
  sig.swap(q.signature);
  const bool used_arena = q.arena_used > 0;
  q.arena_used = 0;
  ++stats_.segments;
  q.may_run = true;
  auto mark_arena = [&] {
    if (!used_arena) return;
    q.arena_busy = true;
    check(cudaEventRecord(q.arena_free, q.stream), "cudaEventRecord(upload staging)");
  };
  try {
    bool launched = false;
    if (graph_mode_ != GraphMode::kOff && ops.size() >= 2) {
      const std::uint64_t hash = hash_signature(sig);
      for (CachedGraph& g : graphs_) {
        if (g.hash == hash && g.signature == sig) {
          g.last_use = ++graph_clock_;
          check(cudaGraphLaunch(g.exec, q.stream), "cudaGraphLaunch", "a cached segment");
          ++stats_.graph_replays;
          launched = true;
          break;
        }
      }
      if (!launched && uncapturable_.count(hash) == 0) {
        if (graph_mode_ == GraphMode::kEager || seen_.count(hash) != 0) {
          seen_.erase(hash);
          launched = capture_and_launch(q, ops, std::move(sig), hash);
        } else {
          if (seen_.size() >= kMaxSeen) seen_.clear();
          seen_.insert(hash);
        }
      }
    }
    if (!launched) {
      run_direct(q, ops);
      ++stats_.direct_segments;
    }
  } catch (...) {
    try {
      mark_arena();
    } catch (...) {
    }
    throw;
  }
  mark_arena();
  // Keep the vectors' storage for the next segment (the Frontend records the same one per frame).
  ops.clear();
  if (q.pending.empty()) q.pending.swap(ops);
  sig.clear();
  if (q.signature.empty()) q.signature.swap(sig);
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
