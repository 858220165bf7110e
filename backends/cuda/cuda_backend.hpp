// The CUDA backend: one device, one non-blocking stream on which every copy, fill and kernel is
// enqueued in call order; device memory from cudaMalloc (never managed memory), a pinned host
// staging buffer for small transfers, grow-only scratch buffers. The kernel contracts of
// DESIGN.md §3 are dispatched from *_ops.cpp to the kernels of *_kernels.cu (kernels.hpp is the
// boundary). Kernels are asynchronous until synchronize() or a download().
#pragma once

#include <cuda_runtime_api.h>

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "porta/backend.hpp"
#include "porta/registry.hpp"

namespace porta::cuda {

/// One device as the selection sees it.
struct DeviceEntry {
  int index = 0;
  std::string name;
  int major = 0;
  int minor = 0;
  std::size_t memory_bytes = 0;
  /// "NVIDIA H100 80GB HBM3 (sm_90, 79 GiB)".
  std::string label() const;
};

/// Every CUDA device, in runtime order. Empty when there is none; `why` then says what the runtime
/// answered ("cudaGetDeviceCount: cudaErrorNoDevice (...)" or "0 devices").
std::vector<DeviceEntry> enumerate_devices(std::string* why = nullptr);

/// "[0] NVIDIA H100 80GB HBM3 (sm_90, 79 GiB); [1] ...".
std::string list_devices(const std::vector<DeviceEntry>& devices);

class CudaBuffer final : public Buffer {
 public:
  CudaBuffer(std::uint8_t* device_ptr, std::size_t bytes, int device)
      : Buffer(bytes), ptr_(device_ptr), device_(device) {}
  ~CudaBuffer() override;
  std::uint8_t* data() const { return ptr_; }

 private:
  std::uint8_t* ptr_;
  int device_;
};

/// The device address of a buffer made by a CudaBackend, as T.
template <typename T>
T* dev(Buffer& b, std::int64_t offset_bytes = 0) {
  return reinterpret_cast<T*>(static_cast<CudaBuffer&>(b).data() + offset_bytes);
}
template <typename T>
const T* dev(const Buffer& b, std::int64_t offset_bytes = 0) {
  return reinterpret_cast<const T*>(static_cast<const CudaBuffer&>(b).data() + offset_bytes);
}

class CudaBackend final : public Backend {
 public:
  /// Selects the device by options.device, else $PORTA_CUDA_DEVICE, else device 0: an index or a
  /// case-insensitive substring of the device name. Throws BackendError listing the devices found.
  explicit CudaBackend(const BackendOptions& options = {});
  ~CudaBackend() override;

  std::string name() const override { return "cuda"; }
  std::string device_name() const override { return device_.label(); }

  std::unique_ptr<Buffer> allocate(std::size_t bytes) override;
  void upload(Buffer& dst, std::size_t dst_offset, const void* src, std::size_t bytes) override;
  void download(const Buffer& src, std::size_t src_offset, void* dst, std::size_t bytes) override;
  void fill(Buffer& dst, std::size_t offset, std::size_t bytes, std::uint8_t value) override;
  void synchronize() override;

  void rectify(const Buffer& src, const Plane& src_plane, const Buffer& map, Buffer& dst,
               const Plane& dst_plane) override;
  void build_pyramid(Buffer& pyramid, const PyramidLayout& layout, const Buffer& resize_table,
                     const std::vector<std::int32_t>& level_offset) override;
  void fast_crf(const Buffer& pyramid, const PyramidLayout& layout, const Buffer& lut, Buffer& responses,
                const PyramidLayout& response_layout, const FastParams& params) override;
  void cull_cells(const Buffer& responses, const PyramidLayout& response_layout,
                  const CellLayout& cell_layout, Buffer& cells) override;
  void pfa_filter(Buffer& cells, const CellLayout& cell_layout, const PfaParams& params) override;
  void compact_keypoints(const Buffer& cells, int total_cells, DeviceList out) override;
  void orient(const Buffer& pyramid, const PyramidLayout& layout, DeviceList keypoints,
              const std::array<int, 16>& umax, const Buffer& boundaries, int bins) override;
  void blur(const Buffer& pyramid, const PyramidLayout& layout, Buffer& blurred,
            const std::array<std::int32_t, 7>& taps) override;
  void orb_describe(const Buffer& blurred, const PyramidLayout& layout, ConstDeviceList keypoints,
                    const Buffer& pattern, Buffer& descriptors) override;
  void stereo_match(const Buffer& left_pyramid, const Buffer& right_pyramid, const PyramidLayout& layout,
                    ConstDeviceList left_keypoints, const Buffer& left_descriptors,
                    ConstDeviceList right_keypoints, const Buffer& right_descriptors,
                    const StereoParams& params, Buffer& matches) override;
  void projection_match(ConstDeviceList keypoints, const Buffer& keypoint_descriptors, const Buffer& queries,
                        const Buffer& query_descriptors, int num_queries,
                        const std::vector<std::int32_t>& scales_q16, Buffer& results) override;

  // ---- for the *_ops.cpp files ----
  cudaStream_t stream() const { return stream_; }
  /// Makes this backend's device current on the calling thread (every entry point does).
  void activate() const;
  /// Scratch device memory that lives as long as the backend, grown on demand (never shrunk);
  /// zero when first allocated or grown.
  Buffer& scratch(const std::string& name, std::size_t bytes);
  /// Rows a culling thread scans at most (MLPT's N_max): $PORTA_CUDA_MLPT_NMAX, default 8.
  int mlpt_nmax() const { return mlpt_nmax_; }

 private:
  void* staging(std::size_t bytes);

  DeviceEntry device_;
  cudaStream_t stream_ = nullptr;
  int mlpt_nmax_ = 8;
  std::map<std::string, std::unique_ptr<Buffer>> scratch_;
  // Pinned staging for transfers up to kStagingLimit bytes; `staging_free_` is recorded after the
  // copy that last read it, so that an upload can return before its copy has run.
  void* staging_ = nullptr;
  std::size_t staging_bytes_ = 0;
  cudaEvent_t staging_free_ = nullptr;
};

}  // namespace porta::cuda
