// porta_cl_enqueue_bench: what the host pays per OpenCL call on a device, the costs that bound the
// opencl backend with frames in flight (docs/BENCHMARKS.md, issue 16: "enqueueing a frame costs its
// host more than the device needs"). Google Benchmark, OpenCL alone (no PortaSLAM code):
//   - SetKernelArg: one clSetKernelArg (a buffer or an int) on a kernel object;
//   - Enqueue: one clEnqueueNDRangeKernel of a kernel that does nothing (256 work-items), from 1,
//     2, 4 or 8 host threads, each with its own in-order queue and kernel object: whether the
//     driver's enqueue cost spreads over threads or is serialised inside it;
//   - IdleQueue: one clFlush or clFinish of a queue with nothing to run;
//   - RoundTrip: one empty kernel enqueued and waited for with clFinish;
//   - WritePinned: a non-blocking clEnqueueWriteBuffer of an image-sized block from pinned memory.
// The queue is flushed every 16 and finished every 256 calls, so the device keeps up; the finish
// is in the time (amortised). Device: $PORTA_OPENCL_DEVICE as an index or a substring of
// "platform: device", else the first GPU, else the first device; none: exit 2 saying so.
#include <CL/cl.h>
#include <benchmark/benchmark.h>

#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace {

void ok(cl_int err, const char* call) {
  if (err == CL_SUCCESS) return;
  std::fprintf(stderr, "porta_cl_enqueue_bench: %s failed with OpenCL error %d\n", call, err);
  std::exit(1);
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string info_string(cl_platform_id p, cl_device_id d) {
  char platform[256] = {}, device[256] = {};
  clGetPlatformInfo(p, CL_PLATFORM_NAME, sizeof(platform) - 1, platform, nullptr);
  clGetDeviceInfo(d, CL_DEVICE_NAME, sizeof(device) - 1, device, nullptr);
  return std::string(platform) + ": " + device;
}

struct Device {
  cl_device_id device = nullptr;
  cl_context context = nullptr;
  cl_program program = nullptr;
  std::string label;
};

const Device& device() {
  static const Device d = [] {
    struct Entry {
      cl_device_id id;
      std::string label;
      bool gpu;
    };
    std::vector<Entry> all;
    cl_uint np = 0;
    if (clGetPlatformIDs(0, nullptr, &np) == CL_SUCCESS && np > 0) {
      std::vector<cl_platform_id> platforms(np);
      clGetPlatformIDs(np, platforms.data(), nullptr);
      for (cl_platform_id p : platforms) {
        cl_uint nd = 0;
        if (clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, 0, nullptr, &nd) != CL_SUCCESS || nd == 0) continue;
        std::vector<cl_device_id> ids(nd);
        clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, nd, ids.data(), nullptr);
        for (cl_device_id id : ids) {
          cl_device_type type = 0;
          clGetDeviceInfo(id, CL_DEVICE_TYPE, sizeof(type), &type, nullptr);
          all.push_back({id, info_string(p, id), (type & CL_DEVICE_TYPE_GPU) != 0});
        }
      }
    }
    if (all.empty()) {
      std::fprintf(stderr, "porta_cl_enqueue_bench: no OpenCL device found (no platform/ICD installed)\n");
      std::exit(2);
    }
    const Entry* pick = nullptr;
    if (const char* want = std::getenv("PORTA_OPENCL_DEVICE"); want != nullptr && *want != '\0') {
      char* end = nullptr;
      const long index = std::strtol(want, &end, 10);
      if (*end == '\0' && index >= 0 && static_cast<std::size_t>(index) < all.size()) pick = &all[index];
      for (const Entry& e : all)
        if (pick == nullptr && lower(e.label).find(lower(want)) != std::string::npos) pick = &e;
      if (pick == nullptr) {
        std::fprintf(stderr, "porta_cl_enqueue_bench: PORTA_OPENCL_DEVICE '%s' names no device\n", want);
        std::exit(2);
      }
    }
    for (const Entry& e : all)
      if (pick == nullptr && e.gpu) pick = &e;
    if (pick == nullptr) pick = &all.front();
    Device out;
    out.device = pick->id;
    out.label = pick->label;
    cl_int err = CL_SUCCESS;
    out.context = clCreateContext(nullptr, 1, &out.device, nullptr, nullptr, &err);
    ok(err, "clCreateContext");
    const char* source =
        "__kernel void nothing(__global int* a, int b, int c, int d) {\n"
        "  if (get_global_id(0) == 0 && b < 0) a[0] = c + d;\n"
        "}\n";
    out.program = clCreateProgramWithSource(out.context, 1, &source, nullptr, &err);
    ok(err, "clCreateProgramWithSource");
    ok(clBuildProgram(out.program, 1, &out.device, "", nullptr, nullptr), "clBuildProgram");
    std::fprintf(stderr, "porta_cl_enqueue_bench: %s\n", out.label.c_str());
    return out;
  }();
  return d;
}

/// A queue, a kernel object and a small buffer of one benchmark thread.
struct Lane {
  cl_command_queue queue = nullptr;
  cl_kernel kernel = nullptr;
  cl_mem buffer = nullptr;
  Lane() {
    const Device& d = device();
    cl_int err = CL_SUCCESS;
    queue = clCreateCommandQueue(d.context, d.device, 0, &err);
    ok(err, "clCreateCommandQueue");
    kernel = clCreateKernel(d.program, "nothing", &err);
    ok(err, "clCreateKernel");
    buffer = clCreateBuffer(d.context, CL_MEM_READ_WRITE, 64, nullptr, &err);
    ok(err, "clCreateBuffer");
    const int zero = 0;
    ok(clSetKernelArg(kernel, 0, sizeof(cl_mem), &buffer), "clSetKernelArg");
    for (cl_uint i = 1; i < 4; ++i) ok(clSetKernelArg(kernel, i, sizeof(int), &zero), "clSetKernelArg");
  }
  ~Lane() {
    clFinish(queue);
    clReleaseMemObject(buffer);
    clReleaseKernel(kernel);
    clReleaseCommandQueue(queue);
  }
  Lane(const Lane&) = delete;
  Lane& operator=(const Lane&) = delete;
};

void BM_SetKernelArg(benchmark::State& state) {
  Lane lane;
  int value = 0;
  const bool buffer = state.range(0) == 1;
  for (auto _ : state) {
    if (buffer) {
      ok(clSetKernelArg(lane.kernel, 0, sizeof(cl_mem), &lane.buffer), "clSetKernelArg");
    } else {
      ++value;
      ok(clSetKernelArg(lane.kernel, 2, sizeof(int), &value), "clSetKernelArg");
    }
  }
  state.SetLabel(buffer ? "buffer" : "int");
}
BENCHMARK(BM_SetKernelArg)->Arg(0)->Arg(1);

void BM_Enqueue(benchmark::State& state) {
  Lane lane;
  const std::size_t global = 256, local = 64;
  std::size_t n = 0;
  for (auto _ : state) {
    ok(clEnqueueNDRangeKernel(lane.queue, lane.kernel, 1, nullptr, &global, &local, 0, nullptr, nullptr),
       "clEnqueueNDRangeKernel");
    ++n;
    if (n % 256 == 0) {
      ok(clFinish(lane.queue), "clFinish");
    } else if (n % 16 == 0) {
      ok(clFlush(lane.queue), "clFlush");
    }
  }
  ok(clFinish(lane.queue), "clFinish");
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));
}
BENCHMARK(BM_Enqueue)->Threads(1)->Threads(2)->Threads(4)->Threads(8)->UseRealTime();

/// What a flush and a finish cost the host on a queue with nothing to run (the backend's flush()
/// once called clFlush on all of its queues per frame).
void BM_IdleQueue(benchmark::State& state) {
  Lane lane;
  const bool finish = state.range(0) == 1;
  ok(clFinish(lane.queue), "clFinish");
  for (auto _ : state) {
    if (finish) {
      ok(clFinish(lane.queue), "clFinish");
    } else {
      ok(clFlush(lane.queue), "clFlush");
    }
  }
  state.SetLabel(finish ? "clFinish" : "clFlush");
}
BENCHMARK(BM_IdleQueue)->Arg(0)->Arg(1);

/// One empty kernel enqueued, flushed and waited for: the round trip of a frame's smallest batch.
void BM_RoundTrip(benchmark::State& state) {
  Lane lane;
  const std::size_t global = 256, local = 64;
  for (auto _ : state) {
    ok(clEnqueueNDRangeKernel(lane.queue, lane.kernel, 1, nullptr, &global, &local, 0, nullptr, nullptr),
       "clEnqueueNDRangeKernel");
    ok(clFinish(lane.queue), "clFinish");
  }
}
BENCHMARK(BM_RoundTrip)->UseRealTime();

void BM_WritePinned(benchmark::State& state) {
  Lane lane;
  const Device& d = device();
  const auto bytes = static_cast<std::size_t>(state.range(0));
  cl_int err = CL_SUCCESS;
  cl_mem target = clCreateBuffer(d.context, CL_MEM_READ_WRITE, bytes, nullptr, &err);
  ok(err, "clCreateBuffer");
  cl_mem pinned = clCreateBuffer(d.context, CL_MEM_READ_WRITE | CL_MEM_ALLOC_HOST_PTR, bytes, nullptr, &err);
  ok(err, "clCreateBuffer");
  void* host = clEnqueueMapBuffer(lane.queue, pinned, CL_TRUE, CL_MAP_READ | CL_MAP_WRITE, 0, bytes, 0, nullptr,
                                  nullptr, &err);
  ok(err, "clEnqueueMapBuffer");
  std::size_t n = 0;
  for (auto _ : state) {
    ok(clEnqueueWriteBuffer(lane.queue, target, CL_FALSE, 0, bytes, host, 0, nullptr, nullptr),
       "clEnqueueWriteBuffer");
    if (++n % 16 == 0) ok(clFinish(lane.queue), "clFinish");
  }
  ok(clFinish(lane.queue), "clFinish");
  clEnqueueUnmapMemObject(lane.queue, pinned, host, 0, nullptr, nullptr);
  clFinish(lane.queue);
  clReleaseMemObject(pinned);
  clReleaseMemObject(target);
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * bytes));
}
BENCHMARK(BM_WritePinned)->Arg(320 * 240)->Arg(1242 * 375);

}  // namespace

BENCHMARK_MAIN();
