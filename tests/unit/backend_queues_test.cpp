// The HAL's queues on the device backends (vulkan, opencl, cuda; lavapipe and PoCL in CI): work on
// one queue that waits for another's sees its results, asynchronous transfers through host buffers
// carry the bytes of the cpu reference, a queue's downloads have landed once it is finished, queue
// numbers out of range and foreign host buffers are clear errors, and $PORTA_VULKAN_QUEUES /
// $PORTA_OPENCL_QUEUES set the count. Each backend runs where a device is; the test says so when not.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "porta/backend.hpp"
#include "porta/registry.hpp"
#include "porta/tables.hpp"
#include "support/backends.hpp"
#include "support/test_images.hpp"

namespace porta {
namespace {

template <typename F>
std::string message_of(F&& call) {
  try {
    call();
  } catch (const BackendError& e) {
    return e.what();
  }
  return "no error";
}

/// One image's pyramid and FAST responses, the way the Frontend lays them out.
struct Scene {
  FrontendSettings settings;
  FrontendTables tables;
  PyramidLayout pyramid, responses;
  std::vector<std::uint8_t> level0;  // the image at level 0's pitch
  explicit Scene(std::uint64_t seed) {
    settings.levels = 4;
    tables = FrontendTables::build(settings, 320, 240);
    pyramid = PyramidLayout::make(tables.level_sizes, 1);
    responses = PyramidLayout::make(tables.level_sizes, 2);
    const Image image = test::textured_image(320, 240, seed);
    level0.assign(static_cast<std::size_t>(pyramid.levels[0].pitch) * 240, 0);
    for (int y = 0; y < 240; ++y)
      std::memcpy(level0.data() + static_cast<std::size_t>(y) * pyramid.levels[0].pitch, image.view().row(y), 320);
  }
};

/// The device objects of one Scene on one backend: the tables uploaded and synchronised.
struct OnDevice {
  std::unique_ptr<Buffer> pyramid, resize, lut, responses;
  OnDevice(Backend& b, const Scene& s)
      : pyramid(b.allocate(static_cast<std::size_t>(s.pyramid.total_bytes))),
        resize(b.allocate(s.tables.resize.packed.size() * 4)),
        lut(b.allocate(s.tables.fast_lut.size())),
        responses(b.allocate(static_cast<std::size_t>(s.responses.total_bytes))) {
    b.upload(*resize, 0, s.tables.resize.packed.data(), s.tables.resize.packed.size() * 4);
    b.upload(*lut, 0, s.tables.fast_lut.data(), s.tables.fast_lut.size());
    b.synchronize();
  }
  // The image in through `in`, the pyramid on `q_pyramid`, FAST on `q_fast` after waiting for it,
  // the responses out through `out`.
  void run(Backend& b, const Scene& s, HostBuffer& in, HostBuffer& out, int q_pyramid, int q_fast) {
    b.use_queue(q_pyramid);
    b.upload_async(*pyramid, 0, in, 0, s.level0.size());
    b.build_pyramid(*pyramid, s.pyramid, *resize, s.tables.resize.level_offset);
    b.use_queue(q_fast);
    b.queue_wait(q_pyramid);
    b.fast_crf(*pyramid, s.pyramid, *lut, *responses, s.responses, FastParams{s.settings.fast_threshold, s.settings.edge});
    b.download_async(*responses, 0, out, 0, responses->size_bytes());
  }
};

std::vector<std::uint8_t> cpu_responses(const Scene& s) {
  auto cpu = BackendRegistry::instance().create("cpu");
  OnDevice d(*cpu, s);
  auto in = cpu->allocate_host(s.level0.size());
  std::memcpy(in->data(), s.level0.data(), s.level0.size());
  auto out = cpu->allocate_host(d.responses->size_bytes());
  d.run(*cpu, s, *in, *out, 0, 0);
  cpu->synchronize();
  return {out->data(), out->data() + out->size_bytes()};
}

class BackendQueues : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    if (!test::backend_available(GetParam())) GTEST_SKIP() << GetParam() << ": no device here (`portaslam backends` says why)";
    backend_ = BackendRegistry::instance().create(GetParam());
  }
  std::unique_ptr<Backend> backend_;
};

TEST_P(BackendQueues, AQueueThatWaitsForAnotherSeesItsResults) {
  Backend& b = *backend_;
  ASSERT_GE(b.queue_count(), 4) << b.name() << " runs frames in flight on queues of their own";
  // Three scenes at once, each on its own pair of queues, then collected in reverse order.
  std::vector<Scene> scenes;
  for (int i = 0; i < 3; ++i) scenes.emplace_back(40 + i);
  std::vector<std::unique_ptr<OnDevice>> devices;
  std::vector<std::unique_ptr<HostBuffer>> ins, outs;
  for (const Scene& s : scenes) {
    devices.push_back(std::make_unique<OnDevice>(b, s));
    ins.push_back(b.allocate_host(s.level0.size()));
    std::memcpy(ins.back()->data(), s.level0.data(), s.level0.size());
    outs.push_back(b.allocate_host(devices.back()->responses->size_bytes()));
  }
  for (int i = 0; i < 3; ++i) devices[i]->run(b, scenes[i], *ins[i], *outs[i], (2 * i + 1) % b.queue_count(), (2 * i) % b.queue_count());
  b.flush();
  for (int i = 2; i >= 0; --i) {
    b.finish_queue((2 * i) % b.queue_count());
    const std::vector<std::uint8_t> want = cpu_responses(scenes[i]);
    ASSERT_EQ(want.size(), outs[i]->size_bytes());
    EXPECT_EQ(0, std::memcmp(want.data(), outs[i]->data(), want.size())) << b.name() << ", scene " << i;
  }
}

TEST_P(BackendQueues, FramesReplayedOnTheSameQueuesKeepTheirOwnBytes) {
  // The same queues and buffers again with another image: a replayed batch (vulkan) or a reused
  // queue reads the new input, and finishing the queue lands the new output.
  Backend& b = *backend_;
  const Scene first(7), second(8);
  OnDevice d(b, first);
  auto in = b.allocate_host(first.level0.size());
  auto out = b.allocate_host(d.responses->size_bytes());
  for (const Scene* s : {&first, &second, &first, &second}) {
    std::memcpy(in->data(), s->level0.data(), s->level0.size());
    d.run(b, *s, *in, *out, 1, 0);
    b.finish_queue(0);
    const std::vector<std::uint8_t> want = cpu_responses(*s);
    EXPECT_EQ(0, std::memcmp(want.data(), out->data(), want.size())) << b.name();
  }
}

TEST_P(BackendQueues, BadQueueNumbersAndForeignHostBuffersAreClearErrors) {
  Backend& b = *backend_;
  const int n = b.queue_count();
  const std::string range = "queues are 0 to " + std::to_string(n - 1);
  EXPECT_NE(message_of([&] { b.use_queue(n); }).find("use_queue(" + std::to_string(n) + "): " + range), std::string::npos);
  EXPECT_NE(message_of([&] { b.queue_wait(-1); }).find("queue_wait(-1): " + range), std::string::npos);
  EXPECT_NE(message_of([&] { b.finish_queue(n + 3); }).find(range), std::string::npos);

  auto buffer = b.allocate(64);
  auto mine = b.allocate_host(64);
  EXPECT_NE(message_of([&] { b.download_async(*buffer, 0, *mine, 32, 64); }).find("outside the host buffer of 64"),
            std::string::npos);
  auto cpu = BackendRegistry::instance().create("cpu");
  auto foreign = cpu->allocate_host(64);
  std::memset(foreign->data(), 0x5A, 64);
  if (b.name() == "opencl") {  // any host memory will do for a non-blocking write
    b.upload_async(*buffer, 0, *foreign, 0, 64);
    b.synchronize();
    std::vector<std::uint8_t> back(64);
    b.download(*buffer, 0, back.data(), 64);
    EXPECT_EQ(back, std::vector<std::uint8_t>(64, 0x5A));
  } else {
    EXPECT_NE(message_of([&] { b.upload_async(*buffer, 0, *foreign, 0, 64); }).find("allocate_host()"),
              std::string::npos);
  }
}

TEST_P(BackendQueues, OneQueueWhenTheEnvironmentSaysSo) {
  const std::string name = GetParam();
  if (name == "cuda") GTEST_SKIP() << "cuda: $PORTA_CUDA_STREAMS=0 (tested with the cuda backend)";
  const std::string variable = name == "vulkan" ? "PORTA_VULKAN_QUEUES" : "PORTA_OPENCL_QUEUES";
  ::setenv(variable.c_str(), "1", 1);
  auto one = BackendRegistry::instance().create(name);
  ::setenv(variable.c_str(), "x", 1);
  const std::string bad = message_of([&] { BackendRegistry::instance().create(name); });
  ::unsetenv(variable.c_str());
  EXPECT_EQ(one->queue_count(), 1);
  EXPECT_NE(bad.find(variable + " must be a queue count from 1 to 8, got 'x'"), std::string::npos) << bad;
  // Everything in call order on queue 0 gives the same bytes.
  const Scene s(9);
  OnDevice d(*one, s);
  auto in = one->allocate_host(s.level0.size());
  std::memcpy(in->data(), s.level0.data(), s.level0.size());
  auto out = one->allocate_host(d.responses->size_bytes());
  d.run(*one, s, *in, *out, 0, 0);
  one->finish_queue(0);
  const std::vector<std::uint8_t> want = cpu_responses(s);
  EXPECT_EQ(0, std::memcmp(want.data(), out->data(), want.size()));
}

INSTANTIATE_TEST_SUITE_P(Devices, BackendQueues, ::testing::Values("vulkan", "opencl", "cuda"),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace porta
