// The OpenCL backend's own choices (the bytes of its kernels are the equivalence suite's business):
// the kernels it picks by device type, the environment switches that override them
// (fused_detection_test.cpp: the fused detection), and its submission thread. Skips, saying why, when this build has no
// OpenCL backend or the machine no OpenCL device.
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "porta/registry.hpp"
#include "support/backends.hpp"
#include "support/scoped_env.hpp"

#if PORTA_HAVE_OPENCL_BACKEND
#include "opencl/opencl_backend.hpp"
#endif

namespace porta {
namespace {

#if PORTA_HAVE_OPENCL_BACKEND

using test::ScopedEnv;

class OpenClBackendTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const BackendInfo info = test::backend_info("opencl");
    if (!info.available) GTEST_SKIP() << "no usable OpenCL device: " << info.detail;
  }
};

TEST_F(OpenClBackendTest, FusedPyramidIsOnWhereTheWorkGroupKernelsRun) {
  // Neither switch set: the defaults (PoCL in CI: a CPU device, both off; a GPU: both on).
  ScopedEnv groups("PORTA_OPENCL_WORK_GROUPS", "");
  ScopedEnv fused("PORTA_OPENCL_FUSED_PYRAMID", "");
  const opencl::OpenClBackend backend;
  EXPECT_EQ(backend.fused_pyramid(), backend.work_groups());
  {
    ScopedEnv on("PORTA_OPENCL_WORK_GROUPS", "on");
    EXPECT_TRUE(opencl::OpenClBackend().fused_pyramid());
  }
  {
    ScopedEnv off("PORTA_OPENCL_WORK_GROUPS", "off");
    EXPECT_FALSE(opencl::OpenClBackend().fused_pyramid());
  }
}

TEST_F(OpenClBackendTest, FusedPyramidSwitchOverridesTheDefaultAndRejectsOtherValues) {
  {
    ScopedEnv on("PORTA_OPENCL_FUSED_PYRAMID", "on");
    ScopedEnv groups("PORTA_OPENCL_WORK_GROUPS", "off");
    EXPECT_TRUE(opencl::OpenClBackend().fused_pyramid());
  }
  {
    ScopedEnv off("PORTA_OPENCL_FUSED_PYRAMID", "off");
    ScopedEnv groups("PORTA_OPENCL_WORK_GROUPS", "on");
    EXPECT_FALSE(opencl::OpenClBackend().fused_pyramid());
  }
  ScopedEnv bad("PORTA_OPENCL_FUSED_PYRAMID", "yes");
  try {
    const opencl::OpenClBackend backend;
    FAIL() << "PORTA_OPENCL_FUSED_PYRAMID=yes was accepted";
  } catch (const BackendError& e) {
    EXPECT_NE(std::string(e.what()).find("PORTA_OPENCL_FUSED_PYRAMID must be on or off, got 'yes'"),
              std::string::npos)
        << e.what();
  }
}

TEST_F(OpenClBackendTest, SubmitThreadIsOnWhereTheWorkGroupKernelsRunAndNeverWhileProfiling) {
  ScopedEnv groups("PORTA_OPENCL_WORK_GROUPS", "");
  ScopedEnv submit("PORTA_OPENCL_SUBMIT_THREAD", "");
  {
    const opencl::OpenClBackend backend;
    EXPECT_EQ(backend.submit_thread(), backend.work_groups());
  }
  {
    ScopedEnv on("PORTA_OPENCL_SUBMIT_THREAD", "on");
    EXPECT_TRUE(opencl::OpenClBackend().submit_thread());
    BackendOptions profiled;
    profiled.profile_kernels = true;
    EXPECT_FALSE(opencl::OpenClBackend(profiled).submit_thread());
  }
  {
    ScopedEnv off("PORTA_OPENCL_SUBMIT_THREAD", "off");
    ScopedEnv on("PORTA_OPENCL_WORK_GROUPS", "on");
    EXPECT_FALSE(opencl::OpenClBackend().submit_thread());
  }
  ScopedEnv bad("PORTA_OPENCL_SUBMIT_THREAD", "1");
  EXPECT_THROW(opencl::OpenClBackend(), BackendError);
}

// What the calling thread does after an enqueue that the worker only makes later: the buffers and
// host memory involved outlive the command, its results are seen after a download, and a failed
// enqueue is thrown by the next call that waits.
TEST_F(OpenClBackendTest, SubmitThreadKeepsOrderBuffersAndErrors) {
  ScopedEnv on("PORTA_OPENCL_SUBMIT_THREAD", "on");
  opencl::OpenClBackend backend;
  ASSERT_TRUE(backend.submit_thread());
  constexpr std::size_t kBytes = 4096;
  auto host = backend.allocate_host(kBytes);
  for (std::size_t i = 0; i < kBytes; ++i) host->data()[i] = static_cast<std::uint8_t>(i * 7 + 1);
  auto buffer = backend.allocate(kBytes);
  backend.fill(*buffer, 0, kBytes, 0xAB);
  backend.upload_async(*buffer, 0, *host, 0, kBytes / 2);  // after the fill, in queue order
  // A buffer given to commands and released before the worker reached them: its release waits.
  {
    auto gone = backend.allocate(kBytes);
    backend.fill(*gone, 0, kBytes, 0x11);
    backend.upload_async(*gone, 0, *host, 0, kBytes);
  }
  auto back = backend.allocate_host(kBytes);
  backend.download_async(*buffer, 0, *back, 0, kBytes);
  backend.flush();
  backend.synchronize();
  for (std::size_t i = 0; i < kBytes; ++i) {
    const auto want = i < kBytes / 2 ? static_cast<std::uint8_t>(i * 7 + 1) : std::uint8_t{0xAB};
    ASSERT_EQ(back->data()[i], want) << "byte " << i;
  }
  // A launch the driver refuses (fast_crf given one argument of eleven): no error where it was
  // made, the error at the next synchronisation, naming the kernel; the backend goes on working.
  backend.launch("detect", "fast_crf", opencl::Range::linear(1), std::int32_t{0});
  try {
    backend.synchronize();
    FAIL() << "the refused launch was not reported";
  } catch (const BackendError& e) {
    EXPECT_NE(std::string(e.what()).find("fast_crf"), std::string::npos) << e.what();
  }
  std::vector<std::uint8_t> bytes(16);
  backend.fill(*buffer, 0, 16, 0x5C);
  backend.download(*buffer, 0, bytes.data(), bytes.size());
  EXPECT_EQ(bytes, std::vector<std::uint8_t>(16, 0x5C));
}

#else

TEST(OpenClBackend, NotBuilt) { GTEST_SKIP() << "this build has no OpenCL backend (PORTA_WITH_OPENCL=OFF or no OpenCL found)"; }

#endif

}  // namespace
}  // namespace porta
