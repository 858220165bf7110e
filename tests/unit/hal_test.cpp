// The HAL pieces that are not kernels: the synchronized buffer, the registry, frontend input checks.
#include <gtest/gtest.h>

#include <cstring>

#include "cpu/cpu_backend.hpp"
#include "porta/frontend.hpp"
#include "porta/registry.hpp"
#include "porta/sync_buffer.hpp"

namespace porta {
namespace {

// A backend with host memory that counts transfers; its kernels are never called here.
class CountingBackend final : public Backend {
 public:
  std::string name() const override { return "counting"; }
  std::string device_name() const override { return "test"; }
  std::unique_ptr<Buffer> allocate(std::size_t bytes) override {
    ++allocations;
    return inner.allocate(bytes);
  }
  void upload(Buffer& d, std::size_t o, const void* s, std::size_t n) override {
    ++uploads;
    inner.upload(d, o, s, n);
  }
  void download(const Buffer& s, std::size_t o, void* d, std::size_t n) override {
    ++downloads;
    inner.download(s, o, d, n);
  }
  void fill(Buffer& d, std::size_t o, std::size_t n, std::uint8_t v) override { inner.fill(d, o, n, v); }
  void synchronize() override {}
  [[noreturn]] static void unused() { throw std::logic_error("kernel not used in this test"); }
  void rectify(const Buffer&, const Plane&, const Buffer&, Buffer&, const Plane&) override { unused(); }
  void build_pyramid(Buffer&, const PyramidLayout&, const Buffer&, const std::vector<std::int32_t>&) override {
    unused();
  }
  void fast_crf(const Buffer&, const PyramidLayout&, const Buffer&, Buffer&, const PyramidLayout&,
                const FastParams&) override {
    unused();
  }
  void cull_cells(const Buffer&, const PyramidLayout&, const CellLayout&, Buffer&) override { unused(); }
  void pfa_filter(Buffer&, const CellLayout&, const PfaParams&) override { unused(); }
  void compact_keypoints(const Buffer&, int, DeviceList) override { unused(); }
  void orient(const Buffer&, const PyramidLayout&, DeviceList, const std::array<int, 16>&, const Buffer&,
              int) override {
    unused();
  }
  void blur(const Buffer&, const PyramidLayout&, Buffer&, const std::array<std::int32_t, 7>&) override { unused(); }
  void orb_describe(const Buffer&, const PyramidLayout&, ConstDeviceList, const Buffer&, Buffer&) override {
    unused();
  }
  void stereo_match(const Buffer&, const Buffer&, const PyramidLayout&, ConstDeviceList, const Buffer&,
                    ConstDeviceList, const Buffer&, const StereoParams&, Buffer&) override {
    unused();
  }
  void projection_match(ConstDeviceList, const Buffer&, const Buffer&, const Buffer&, int,
                        const std::vector<std::int32_t>&, Buffer&) override {
    unused();
  }

  cpu::CpuBackend inner{1};
  int allocations = 0, uploads = 0, downloads = 0;
};

TEST(SyncBuffer, CopiesOnlyWhenTheOtherSideIsNewer) {
  CountingBackend backend;
  SyncBuffer<int> buf(backend);
  buf.resize(4);
  int* h = buf.host_write();
  for (int i = 0; i < 4; ++i) h[i] = i + 1;
  EXPECT_EQ(backend.uploads, 0);
  const Buffer& d = buf.device_read();  // host newer: one upload
  EXPECT_EQ(backend.uploads, 1);
  buf.device_read();  // in sync: nothing
  EXPECT_EQ(backend.uploads, 1);
  int back[4] = {};
  backend.inner.download(d, 0, back, sizeof(back));
  EXPECT_EQ(back[3], 4);

  Buffer& w = buf.device_write();  // a kernel writes on the device
  const int seven = 7;
  backend.inner.upload(w, 0, &seven, sizeof(seven));
  EXPECT_EQ(backend.downloads, 0);
  EXPECT_EQ(buf.host_read()[0], 7);  // device newer: one download
  EXPECT_EQ(backend.downloads, 1);
  buf.host_read();
  EXPECT_EQ(backend.downloads, 1);
}

TEST(SyncBuffer, GrowsWithoutShrinkingAndKeepsContents) {
  CountingBackend backend;
  SyncBuffer<std::uint32_t> buf(backend);
  buf.resize(100);
  buf.host_write()[99] = 42;
  const auto allocs = buf.allocations();
  for (int frame = 0; frame < 50; ++frame) {
    buf.resize(static_cast<std::size_t>(10 + (frame * 37) % 90));  // variable per-frame counts
    buf.device_write();
  }
  EXPECT_EQ(buf.allocations(), allocs) << "a size below capacity must not reallocate";
  buf.resize(100);
  buf.host_write()[0] = 1;
  buf.resize(1000);  // growth keeps what was there
  EXPECT_EQ(buf.host_read()[0], 1u);
  EXPECT_GE(buf.capacity(), 1000u);
}

// The queue and asynchronous-transfer calls of an in-order backend (the HAL's defaults): queue 0
// only, copies at once, every bad number or range a BackendError naming the call.
TEST(HalQueues, InOrderBackendHasQueueZeroAndCopiesAtOnce) {
  cpu::CpuBackend backend(1);
  EXPECT_EQ(backend.queue_count(), 1);
  backend.use_queue(0);
  backend.queue_wait(0);
  backend.finish_queue(0);
  auto message_of = [](auto&& call) {
    try {
      call();
    } catch (const BackendError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message_of([&] { backend.use_queue(1); }), "cpu: use_queue(1): queues are 0 to 0");
  EXPECT_EQ(message_of([&] { backend.queue_wait(-1); }), "cpu: queue_wait(-1): queues are 0 to 0");
  EXPECT_EQ(message_of([&] { backend.finish_queue(2); }), "cpu: finish_queue(2): queues are 0 to 0");

  auto device = backend.allocate(16);
  auto host = backend.allocate_host(16);
  ASSERT_EQ(host->size_bytes(), 16u);
  for (std::size_t i = 0; i < 16; ++i) EXPECT_EQ(host->data()[i], 0) << "zero-filled";
  for (std::size_t i = 0; i < 16; ++i) host->data()[i] = static_cast<std::uint8_t>(i + 1);
  backend.upload_async(*device, 4, *host, 0, 8);
  auto back = backend.allocate_host(16);
  backend.download_async(*device, 0, *back, 2, 12);
  backend.finish_queue(0);
  const std::uint8_t want[16] = {0, 0, 0, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 0, 0};
  EXPECT_EQ(0, std::memcmp(back->data(), want, 16));

  EXPECT_EQ(message_of([&] { backend.upload_async(*device, 0, *host, 10, 8); }),
            "cpu: upload_async: range [10, +8) is outside the host buffer of 16 bytes");
  EXPECT_EQ(message_of([&] { backend.download_async(*device, 0, *back, 17, 0); }),
            "cpu: download_async: range [17, +0) is outside the host buffer of 16 bytes");
}

TEST(Registry, ListsEveryKnownBackendAndCpuIsAvailable) {
  const auto list = BackendRegistry::instance().list();
  ASSERT_EQ(list.size(), 4u);
  EXPECT_EQ(list[0].name, "cpu");
  EXPECT_TRUE(list[0].compiled);
  EXPECT_TRUE(list[0].available);
  auto cpu = BackendRegistry::instance().create("cpu");
  EXPECT_EQ(cpu->name(), "cpu");
}

TEST(Registry, UnknownOrMissingBackendIsAClearError) {
  try {
    BackendRegistry::instance().create("metal");
    FAIL();
  } catch (const BackendError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown backend 'metal'"), std::string::npos) << e.what();
  }
  for (const auto& info : BackendRegistry::instance().list()) {
    if (info.compiled) continue;
    try {
      BackendRegistry::instance().create(info.name);
      FAIL() << info.name << " created although not built";
    } catch (const BackendError& e) {
      EXPECT_NE(std::string(e.what()).find("not built"), std::string::npos) << e.what();
    }
  }
}

TEST(Frontend, RejectsAnImageOfTheWrongSizeByName) {
  cpu::CpuBackend backend(1);
  Frontend frontend(backend, FrontendSettings{}, 64, 48);
  Image wrong(65, 48);
  try {
    frontend.detect(wrong.view());
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("65x48"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("64x48"), std::string::npos) << e.what();
  }
  EXPECT_THROW(frontend.detect(ImageView{}), std::invalid_argument);
}

TEST(Frontend, RejectsBadSettingsBeforeTouchingTheDevice) {
  CountingBackend backend;
  FrontendSettings s;
  s.cell_width = 0;
  EXPECT_THROW(Frontend(backend, s, 64, 48), SettingsError);
  EXPECT_EQ(backend.allocations, 0);
}

}  // namespace
}  // namespace porta
