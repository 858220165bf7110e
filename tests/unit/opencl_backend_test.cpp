// The OpenCL backend's own choices (the bytes of its kernels are the equivalence suite's business):
// the kernels it picks by device type, and the environment switches that override them
// (fused_detection_test.cpp: the fused detection). Skips, saying why, when this build has no
// OpenCL backend or the machine no OpenCL device.
#include <gtest/gtest.h>

#include <string>

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

#else

TEST(OpenClBackend, NotBuilt) { GTEST_SKIP() << "this build has no OpenCL backend (PORTA_WITH_OPENCL=OFF or no OpenCL found)"; }

#endif

}  // namespace
}  // namespace porta
