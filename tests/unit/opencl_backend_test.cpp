// The OpenCL backend's own choices (the bytes of its kernels are the equivalence suite's business):
// the kernels it picks by device type, and the environment switches that override them; a small
// frame's detection in one launch, byte for byte the cpu backend's. Skips, saying why, when this
// build has no OpenCL backend or the machine no OpenCL device.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <memory>
#include <optional>
#include <string>

#include "porta/frontend.hpp"
#include "porta/kernel_profile.hpp"
#include "porta/registry.hpp"
#include "support/backends.hpp"
#include "support/test_images.hpp"

#if PORTA_HAVE_OPENCL_BACKEND
#include "opencl/opencl_backend.hpp"
#endif

namespace porta {
namespace {

#if PORTA_HAVE_OPENCL_BACKEND

/// Sets an environment variable for one scope, then restores what was there.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const char* value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    ::setenv(name, value, 1);
  }
  ~ScopedEnv() {
    if (old_) {
      ::setenv(name_, old_->c_str(), 1);
    } else {
      ::unsetenv(name_);
    }
  }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  const char* name_;
  std::optional<std::string> old_;
};

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

std::uint64_t dispatches_of(const std::vector<KernelTime>& times, const char* kernel) {
  for (const KernelTime& t : times)
    if (t.kernel == kernel) return t.dispatches;
  return 0;
}

bool same_bytes(const Features& a, const Features& b) {
  return a.keypoints.size() == b.keypoints.size() && a.descriptors.size() == b.descriptors.size() &&
         std::memcmp(a.keypoints.data(), b.keypoints.data(), a.keypoints.size() * sizeof(Keypoint)) == 0 &&
         std::memcmp(a.descriptors.data(), b.descriptors.data(), a.descriptors.size() * sizeof(Descriptor)) == 0;
}

TEST_F(OpenClBackendTest, FusedDetectionGivesTheCpuBackendsBytesInFewerLaunches) {
  // The work-group kernels forced on (PoCL runs them as loops): FAST with culling in one launch
  // (fast_cull_group), PFA with the compaction in one more up to 512 cells (pfa_compact_group),
  // the separate launches beyond. Each checked against the cpu backend, keypoints, descriptors and
  // matches byte for byte: PFA on and off, cells of 32, 16 and 8 pixels, one, two and eight levels,
  // and the fusion switched off.
  ScopedEnv groups("PORTA_OPENCL_WORK_GROUPS", "on");
  struct Case {
    int width, height, levels, cell;
    bool pfa;
    const char* env;  // PORTA_OPENCL_FUSED_DETECT
    std::uint64_t fast_cull, pfa_compact;  // dispatches per stereo pair
  };
  const Case cases[] = {
      {320, 240, 1, 32, true, "", 2, 2},   {320, 240, 1, 16, true, "", 2, 2},   {320, 240, 1, 32, false, "", 2, 2},
      {256, 200, 2, 32, true, "", 2, 2},   {320, 240, 1, 8, true, "", 2, 0},  // 1 200 cells
      {640, 480, 8, 32, true, "", 2, 0},   {320, 240, 1, 32, true, "off", 0, 0},  // 8 levels: 852 cells
  };
  auto cpu = BackendRegistry::instance().create("cpu", {});
  for (const Case& c : cases) {
    SCOPED_TRACE(std::to_string(c.width) + "x" + std::to_string(c.height) + " levels " + std::to_string(c.levels) +
                 " cell " + std::to_string(c.cell) + (c.pfa ? " pfa" : " no pfa") + " env '" + c.env + "'");
    ScopedEnv fused_switch("PORTA_OPENCL_FUSED_DETECT", c.env);
    BackendOptions options;
    options.profile_kernels = true;
    opencl::OpenClBackend backend(options);
    FrontendSettings settings;
    settings.levels = c.levels;
    settings.cell_width = settings.cell_height = c.cell;
    settings.pfa = c.pfa;
    const Image left = test::textured_image(c.width, c.height, 11), right = test::shifted_right(left, 5);
    Frontend on_cl(backend, settings, c.width, c.height), on_cpu(*cpu, settings, c.width, c.height);
    const StereoFeatures got = on_cl.detect_stereo(left.view(), right.view());
    const StereoFeatures want = on_cpu.detect_stereo(left.view(), right.view());
    ASSERT_GT(want.left.keypoints.size(), 10u) << "the test image should have corners";
    EXPECT_TRUE(same_bytes(got.left, want.left));
    EXPECT_TRUE(same_bytes(got.right, want.right));
    ASSERT_EQ(got.matches.size(), want.matches.size());
    EXPECT_EQ(std::memcmp(got.matches.data(), want.matches.data(), got.matches.size() * sizeof(StereoMatch)), 0);
    const std::vector<KernelTime> times = backend.kernel_times(true);
    EXPECT_EQ(dispatches_of(times, "fast_cull_group"), c.fast_cull);
    EXPECT_EQ(dispatches_of(times, "pfa_compact_group"), c.pfa_compact);
    EXPECT_EQ(dispatches_of(times, "fast_tiled"), c.fast_cull > 0 ? 0u : 2u);
  }
  ScopedEnv bad("PORTA_OPENCL_FUSED_DETECT", "yes");
  try {
    const opencl::OpenClBackend backend;
    FAIL() << "PORTA_OPENCL_FUSED_DETECT=yes was accepted";
  } catch (const BackendError& e) {
    EXPECT_NE(std::string(e.what()).find("PORTA_OPENCL_FUSED_DETECT must be on or off, got 'yes'"), std::string::npos)
        << e.what();
  }
}

#else

TEST(OpenClBackend, NotBuilt) { GTEST_SKIP() << "this build has no OpenCL backend (PORTA_WITH_OPENCL=OFF or no OpenCL found)"; }

#endif

}  // namespace
}  // namespace porta
