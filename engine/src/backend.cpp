// The HAL's default asynchronous transfers: plain host memory and copies made at once, which is
// what a backend that runs everything in call order needs.
#include "porta/backend.hpp"

#include <vector>

namespace porta {

namespace {

class PlainHostBuffer final : public HostBuffer {
 public:
  explicit PlainHostBuffer(std::size_t bytes) : PlainHostBuffer(std::vector<std::uint8_t>(bytes, 0)) {}

 private:
  explicit PlainHostBuffer(std::vector<std::uint8_t> storage)
      : HostBuffer(storage.data(), storage.size()), storage_(std::move(storage)) {}
  std::vector<std::uint8_t> storage_;  // moved in after data() was taken: the pointer stays valid
};

}  // namespace

void check_host_range(const HostBuffer& buffer, std::size_t offset, std::size_t bytes, const std::string& backend,
                      const char* call) {
  if (offset > buffer.size_bytes() || bytes > buffer.size_bytes() - offset)
    throw BackendError(backend + ": " + call + ": range [" + std::to_string(offset) + ", +" + std::to_string(bytes) +
                       ") is outside the host buffer of " + std::to_string(buffer.size_bytes()) + " bytes");
}

void Backend::check_queue_index(int queue, const char* call) const {
  if (queue < 0 || queue >= queue_count())
    throw BackendError(name() + ": " + call + "(" + std::to_string(queue) + "): queues are 0 to " +
                       std::to_string(queue_count() - 1));
}

void Backend::detect_keypoints(const Buffer& pyramid, const PyramidLayout& layout, const Buffer& lut,
                               Buffer& responses, const PyramidLayout& response_layout, const FastParams& fast,
                               const CellLayout& cell_layout, Buffer& cells, const PfaParams* pfa,
                               DeviceList out) {
  fast_crf(pyramid, layout, lut, responses, response_layout, fast);
  cull_cells(responses, response_layout, cell_layout, cells);
  if (pfa != nullptr) pfa_filter(cells, cell_layout, *pfa);
  compact_keypoints(cells, cell_layout.total_cells, out);
}

std::unique_ptr<HostBuffer> Backend::allocate_host(std::size_t bytes) {
  return std::make_unique<PlainHostBuffer>(bytes);
}

void Backend::upload_async(Buffer& dst, std::size_t dst_offset, const HostBuffer& src, std::size_t src_offset,
                           std::size_t bytes) {
  check_host_range(src, src_offset, bytes, name(), "upload_async");
  upload(dst, dst_offset, src.data() + src_offset, bytes);
}

void Backend::download_async(const Buffer& src, std::size_t src_offset, HostBuffer& dst, std::size_t dst_offset,
                             std::size_t bytes) {
  check_host_range(dst, dst_offset, bytes, name(), "download_async");
  download(src, src_offset, dst.data() + dst_offset, bytes);
}

}  // namespace porta
