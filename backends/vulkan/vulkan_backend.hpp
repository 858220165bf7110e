// The Vulkan backend (Vulkan 1.1+ compute): one device, several queues; every kernel of
// DESIGN.md §3 is a GLSL compute shader of shaders/vulkan, compiled to SPIR-V at build time and
// embedded in the library (cmake/EmbedSpirv.cmake). This header names no Vulkan type: the Vulkan
// objects live in vk_runtime.hpp / vk_context.hpp, which only the backend's own files include.
//
// How work reaches the device (vk_runtime.hpp, vk_streams.cpp):
//  * The HAL's queues are streams (Runtime::kStreams of them, spread over up to eight queues of the
//    device's compute family). Kernel calls record into the current stream's pending batch; the
//    batch is submitted by flush(), by a queue_wait() that names its stream, or by a wait
//    (finish_queue(), synchronize(), a download, or a full staging or parameter area). A stream
//    has at most one batch on the device: recording into it again first waits for that one. A full
//    compute/transfer memory barrier separates consecutive commands; queue_wait() is a semaphore
//    between two streams' batches. A batch whose commands equal those of an earlier one of its
//    stream (same kernels, buffers, parameter offsets, push constants and sizes) replays that
//    batch's command buffer instead of recording a new one: a Frontend's frames are recorded once
//    and replayed. $PORTA_VULKAN_QUEUES=1 gives one queue (everything in call order).
//  * Host buffers (allocate_host) are mapped host-visible memory that the device copies to and from
//    inside the batch: a Frontend frame is one submit per stream, its inputs and results included.
//  * Pipelines are created on first use, once per kernel; descriptor sets are cached by the
//    buffers they bind, so frames that reuse their buffers allocate none (see stats()).
//  * Kernel buffers are device-local. Where that memory is also host-visible, coherent and
//    cached (unified memory, e.g. lavapipe) the host reads and writes it directly; otherwise
//    uploads and downloads go through a host-visible staging buffer grown on demand.
//
// Adding a kernel (the pattern every *_kernels.cpp follows):
//  1. Write shaders/vulkan/<kernel>.comp: `#version 450`, `#extension GL_GOOGLE_include_directive
//     : require`, `#include "common.glsl"` (8/16-bit storage, keypoint packing, index helpers),
//     a `layout(local_size_x = ...) in;`, its buffers as `layout(std430, set = 0, binding = i)
//     buffer ...` with bindings 0..N-1 in the order the host passes them, and its parameters as
//       - `layout(std430, push_constant) uniform Params { ... } p;` when they fit 128 bytes, or
//       - `layout(std430, set = 1, binding = 0) readonly buffer Params { ... } p;` when larger
//         (a per-dispatch slice of a host-visible parameter buffer; at most kMaxParamsBytes).
//     The file is picked up by the build (glob) and embedded under the name <kernel>.
//  2. Mirror the parameter block in a host struct with the same std430 layout (vk_types.hpp has
//     the shared ones: GlslPlane, GlslLevels, GlslCells, with static_asserts). The shader reads
//     keypoint arrays as `uvec2` (common.glsl kp_x() ... make_keypoint()), so 8/16-bit arithmetic
//     is never needed. Write the .comp as a port of the cpu kernel: same integer types and
//     rounding; outputs in canonical order (no order-dependent atomics).
//  3. In the kernel method: check the arguments as the cpu backend does (throw BackendError
//     "vulkan: <kernel>: ..."), then
//       rt().dispatch("<kernel>", {&buffer0, &buffer1, ...}, params, Work::items(n));
//     with Work::items(n) (one invocation per item; the shader takes porta_linear_index()),
//     Work::grid(w, h) (2-D, gl_GlobalInvocationID.xy) or Work::groups(n) (one workgroup per
//     item; porta_linear_group()). The runtime checks the shader's bindings and parameter block
//     against the call (a mismatch throws, naming the kernel), creates the pipeline on first use
//     and caches the descriptor set. Scratch memory that lives as long as the backend: scratch().
//  Shaders must not depend on the subgroup size (lavapipe's is 8, NVIDIA's 32): reduce through
//  shared memory and barrier(), or with atomics whose result does not depend on order.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "porta/backend.hpp"
#include "porta/kernel_checks.hpp"
#include "porta/registry.hpp"

namespace porta::vulkan {

class Runtime;  // vk_runtime.hpp

/// Counters of Vulkan object creation and submission since the backend was created; tests use
/// them to check that a steady frame loop creates nothing.
struct VulkanStats {
  std::uint64_t buffers_allocated = 0;
  std::uint64_t pipelines_created = 0;
  std::uint64_t descriptor_sets_allocated = 0;
  std::uint64_t command_buffers_recorded = 0;  ///< batches recorded (cache misses)
  std::uint64_t command_buffers_replayed = 0;  ///< batches that reused a recorded command buffer
  std::uint64_t submits = 0;
  std::uint64_t merged_batches = 0;  ///< batches merged into another (stream_wait, held batches)
  std::uint64_t held_batches = 0;    ///< batches start() held back or merged into a held one while the device was busy
  std::uint64_t commands_recorded = 0;  ///< dispatches, copies and fills in recorded command buffers
  std::uint64_t barriers_recorded = 0;  ///< barriers between them (not counting each batch's first and last)
  std::uint64_t transfer_queue_copies = 0;  ///< upload_async copies submitted to the transfer queue
};

class VulkanBackend final : public Backend {
 public:
  /// Selects the device by options.device, else $PORTA_VULKAN_DEVICE, else the first discrete,
  /// integrated, virtual, then cpu device: an index or a case-insensitive part of its name.
  /// $PORTA_VULKAN_VALIDATION=1 enables the Khronos validation layer (on by default in debug
  /// builds when installed); its errors are thrown as BackendError at the next submit.
  explicit VulkanBackend(const BackendOptions& options = {});
  ~VulkanBackend() override;

  std::string name() const override { return "vulkan"; }
  std::string device_name() const override;

  std::unique_ptr<Buffer> allocate(std::size_t bytes) override;
  void upload(Buffer& dst, std::size_t dst_offset, const void* src, std::size_t bytes) override;
  void download(const Buffer& src, std::size_t src_offset, void* dst, std::size_t bytes) override;
  void fill(Buffer& dst, std::size_t offset, std::size_t bytes, std::uint8_t value) override;
  void synchronize() override;
  void flush() override;
  std::vector<KernelTime> kernel_times(bool reset) override;

  /// Runtime::kStreams, or $PORTA_VULKAN_QUEUES (1 to kStreams).
  int queue_count() const override { return queues_; }
  /// allocate_host: mapped host-visible memory the device copies from and to in the queue's batch;
  /// upload_async / download_async: `src` / `dst` must come from it (BackendError otherwise).
  PORTA_BACKEND_QUEUE_OVERRIDES;

  PORTA_BACKEND_KERNEL_OVERRIDES;
  /// With fused_detect(): FAST, culling and PFA's step A in one dispatch (fast_cull.comp), PFA's
  /// other steps and the compaction in one more (pfa_compact_group.comp; above 512 cells with
  /// pfa_decide.comp between them), or all of it in one up to 512 cells
  /// (fast_cull_finish.comp); otherwise the four kernels' dispatches.
  void detect_keypoints(const Buffer& pyramid, const PyramidLayout& layout, const Buffer& lut, Buffer& responses,
                        const PyramidLayout& response_layout, const porta::FastParams& fast,
                        const CellLayout& cell_layout, Buffer& cells, const porta::PfaParams* pfa,
                        DeviceList out) override;

  VulkanStats stats() const;
  /// True when the Khronos validation layer is active.
  bool validation_enabled() const;
  /// True when upload_async's copies may run on a queue of a transfer-only family (a GPU's copy
  /// engines) beside the kernels: the default where the device has one.
  bool uploads_on_copy_engines() const;

  // ---- for the kernel files ----
  Runtime& rt() { return *runtime_; }
  /// Device memory that lives as long as the backend, grown on demand (never shrunk); the
  /// contents are unspecified after growth (zero when first made). One per queue: queues never
  /// share scratch memory.
  Buffer& scratch(const std::string& name, std::size_t bytes);
  /// Kernels with a workgroup per item (orient.comp) rather than an invocation per item
  /// (orient_per_item.comp), per 32 x 8 tile of all levels with shared memory (fast_tiled.comp,
  /// blur_tiled.comp: one dispatch where the blur had two), and PFA and compaction in one workgroup
  /// (pfa_group.comp, compact_group.comp) rather than three dispatches each: on GPUs that run
  /// workgroups of 256, not on a CPU device (lavapipe), where they are slower.
  /// $PORTA_VULKAN_WORK_GROUPS=on or off overrides (the equivalence suite runs both on lavapipe).
  /// The bytes are the same either way.
  bool work_groups() const { return work_groups_; }
  /// Whether detect_keypoints fuses its kernels: where work_groups() is on (and the device runs
  /// workgroups of 1024); $PORTA_VULKAN_FUSED_DETECT=on or off overrides.
  bool fused_detect() const { return fused_detect_; }
  /// With fused_detect(): whether fast_cull.comp also does PFA's step A, pfa_compact_group.comp the
  /// rest (with pfa_decide.comp between them above 512 cells); or, as before that, PFA runs whole
  /// in pfa_compact_group.comp up to 512 cells and as pfa_filter above
  /// ($PORTA_VULKAN_PFA_IN_CULL=on, the default, or off). The same bytes either way.
  bool pfa_in_cull() const { return pfa_in_cull_; }
  /// With fused_detect() and pfa_in_cull(): whether detection of up to 512 cells is one dispatch,
  /// the cull's last workgroup running PFA's other steps and the compaction
  /// (fast_cull_finish.comp), rather than two ($PORTA_VULKAN_CULL_FINISHES=on, the default, or
  /// off). The same bytes either way.
  bool fused_detect_finish() const { return fused_detect_finish_; }
  /// fast_cull.comp's pixels per invocation (checks::plan_cell_groups): 0, the default, for its
  /// rule by the grid's size; $PORTA_VULKAN_CULL_PIXELS=N (1 to 1024) for N in every grid.
  /// The same bytes either way.
  int cull_pixels() const { return cull_pixels_; }

 private:
  std::shared_ptr<Runtime> runtime_;  // shared with the buffers it made, which may outlive it
  bool work_groups_ = true;
  /// How many levels build_pyramid_fused.comp builds in one dispatch: 32 x 8 tiles, 8 KiB regions
  /// (its REGION_WORDS * 4).
  checks::FusedPyramidLevels fused_levels_{32, 8, 8192};
  /// Whether build_pyramid fuses levels ($PORTA_VULKAN_FUSED_PYRAMID=on; off by default).
  bool fused_pyramid_ = false;
  bool fused_detect_ = false;
  bool pfa_in_cull_ = true;
  bool fused_detect_finish_ = true;
  int cull_pixels_ = 0;
  int queues_ = 1;
  std::map<std::pair<int, std::string>, std::unique_ptr<Buffer>> scratch_;  // key: queue, name
};

}  // namespace porta::vulkan
