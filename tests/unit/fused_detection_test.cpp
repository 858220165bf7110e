// Backend::detect_keypoints fused on the GPU backends (opencl and vulkan, their work-group
// kernels forced on so that PoCL and lavapipe run them in CI): FAST with culling and PFA's step A
// in one launch, PFA's other steps with the compaction in one more (with PFA's step B in a launch
// between them above 512 cells; on vulkan up to 512 cells, in the cull's last work-group), checked against
// the cpu backend byte for byte (keypoints, descriptors, stereo matches) with PFA on and off, cells of 32, 16
// and 8 pixels, one, two and four levels, PFA's step A left to PFA's own launches (the *_PFA_IN_CULL switch:
// PFA whole in the compaction's work-group up to 512 cells, pfa_filter's three launches above) and the fusion
// switched off; bad switch values and bad arguments are clear errors. Skips, saying why, where the
// backend has no device.
#include <gtest/gtest.h>

#include <cstring>
#include <ostream>
#include <string>
#include <vector>

#include "porta/frontend.hpp"
#include "porta/kernel_profile.hpp"
#include "porta/registry.hpp"
#include "porta/tables.hpp"
#include "support/backends.hpp"
#include "support/scoped_env.hpp"
#include "support/test_images.hpp"

namespace porta {
namespace {

using test::ScopedEnv;

struct FusedBackend {
  const char* name;
  const char* work_groups_env;  // forces the GPU kernels on
  const char* fused_env;        // the fusion's own switch
  const char* in_cull_env;      // PFA's step A in the cull's launch
  const char* finish_env;       // the cull's last work-group finishing detection (vulkan), or nullptr
  const char* fast_cull;        // the kernels' names in kernel_times()
  const char* pfa_compact;
  const char* fast_alone;
  const char* cull_finish;  // the cull that finishes detection (vulkan), or nullptr
};

// Its name in ctest's list (gtest would print the struct's bytes, pointers that change per build).
void PrintTo(const FusedBackend& b, std::ostream* os) { *os << b.name; }

std::uint64_t dispatches_of(const std::vector<KernelTime>& times, const std::string& kernel) {
  for (const KernelTime& t : times)
    if (t.kernel == kernel) return t.dispatches;
  return 0;
}

bool same_bytes(const Features& a, const Features& b) {
  return a.keypoints.size() == b.keypoints.size() && a.descriptors.size() == b.descriptors.size() &&
         std::memcmp(a.keypoints.data(), b.keypoints.data(), a.keypoints.size() * sizeof(Keypoint)) == 0 &&
         std::memcmp(a.descriptors.data(), b.descriptors.data(), a.descriptors.size() * sizeof(Descriptor)) == 0;
}

class FusedDetection : public ::testing::TestWithParam<FusedBackend> {};

TEST_P(FusedDetection, GivesTheCpuBackendsBytesInFewerLaunches) {
  const FusedBackend& b = GetParam();
  if (!test::backend_available(b.name)) GTEST_SKIP() << b.name << ": no device here (`portaslam backends` says why)";
  ScopedEnv groups(b.work_groups_env, "on");
  struct Case {
    int width, height, levels, cell;
    bool pfa;
    const char* fused;    // the fusion's switch ("": its default)
    const char* in_cull;  // PFA's step A in the cull's launch ("": its default, on)
    const char* finish;   // the cull's last work-group finishing detection, where the backend can
    // Launches per stereo pair where the cull does not finish detection: fast_cull,
    // pfa_compact_group, pfa_decide, pfa_accumulate.
    std::uint64_t fast_cull, pfa_compact, decide, accumulate;
    bool finishes;  // up to 512 cells, the cull finishes detection where the backend can
  };
  const Case cases[] = {
      {320, 240, 1, 32, true, "", "", "", 2, 2, 0, 0, true},      // 80 cells
      {320, 240, 1, 16, true, "", "", "", 2, 2, 0, 0, true},      // 300
      {320, 240, 1, 32, false, "", "", "", 2, 2, 0, 0, true},     // 80
      {256, 200, 2, 32, true, "", "", "", 2, 2, 0, 0, true},      // 100
      {320, 240, 1, 8, true, "", "", "", 2, 2, 2, 0, false},      // 1 200: above the 512 of one work-group
      {320, 240, 4, 16, true, "", "", "", 2, 2, 2, 0, false},     // 546, 4 levels
      {640, 480, 1, 8, false, "", "", "", 2, 2, 0, 0, false},     // 4 800, the compaction alone
      {320, 240, 1, 32, true, "", "off", "", 2, 2, 0, 0, false},  // 80: PFA whole in the compaction's group
      {320, 240, 1, 8, true, "", "off", "", 2, 0, 2, 2, false},   // 1 200: pfa_filter's three launches
      {320, 240, 1, 32, true, "", "", "off", 2, 2, 0, 0, false},  // 80, the cull not finishing
      {320, 240, 1, 32, true, "off", "", "", 0, 0, 0, 0, false},
  };
  auto cpu = BackendRegistry::instance().create("cpu", {});
  for (const Case& c : cases) {
    SCOPED_TRACE(std::to_string(c.width) + "x" + std::to_string(c.height) + " levels " +
                 std::to_string(c.levels) + " cell " + std::to_string(c.cell) + (c.pfa ? " pfa" : " no pfa") +
                 " switches '" + c.fused + "' '" + c.in_cull + "'");
    ScopedEnv fused(b.fused_env, c.fused);
    ScopedEnv in_cull(b.in_cull_env, c.in_cull);
    ScopedEnv finish(b.finish_env != nullptr ? b.finish_env : "PORTA_TEST_UNUSED", c.finish);
    const bool finishes = c.finishes && b.cull_finish != nullptr;
    BackendOptions options;
    options.profile_kernels = true;
    auto backend = BackendRegistry::instance().create(b.name, options);
    FrontendSettings settings;
    settings.levels = c.levels;
    settings.cell_width = settings.cell_height = c.cell;
    settings.pfa = c.pfa;
    const Image left = test::textured_image(c.width, c.height, 11), right = test::shifted_right(left, 5);
    Frontend on_gpu(*backend, settings, c.width, c.height), on_cpu(*cpu, settings, c.width, c.height);
    const StereoFeatures got = on_gpu.detect_stereo(left.view(), right.view());
    const StereoFeatures want = on_cpu.detect_stereo(left.view(), right.view());
    ASSERT_GT(want.left.keypoints.size(), 10u) << "the test image should have corners";
    EXPECT_TRUE(same_bytes(got.left, want.left));
    EXPECT_TRUE(same_bytes(got.right, want.right));
    ASSERT_EQ(got.matches.size(), want.matches.size());
    EXPECT_EQ(std::memcmp(got.matches.data(), want.matches.data(), got.matches.size() * sizeof(StereoMatch)), 0);
    const std::vector<KernelTime> times = backend->kernel_times(true);
    EXPECT_EQ(dispatches_of(times, b.fast_cull), finishes ? 0u : c.fast_cull);
    EXPECT_EQ(dispatches_of(times, b.pfa_compact), finishes ? 0u : c.pfa_compact);
    if (b.cull_finish != nullptr) {
      EXPECT_EQ(dispatches_of(times, b.cull_finish), finishes ? c.fast_cull : 0u);
    }
    EXPECT_EQ(dispatches_of(times, "pfa_decide"), c.decide);
    EXPECT_EQ(dispatches_of(times, "pfa_accumulate"), c.accumulate);
    EXPECT_EQ(dispatches_of(times, b.fast_alone), c.fast_cull > 0 ? 0u : 2u);
  }
  for (const char* env : {b.fused_env, b.in_cull_env, b.finish_env}) {
    if (env == nullptr) continue;
    ScopedEnv bad(env, "yes");
    try {
      BackendRegistry::instance().create(b.name, {});
      ADD_FAILURE() << env << "=yes was accepted";
    } catch (const BackendError& e) {
      EXPECT_NE(std::string(e.what()).find(std::string(env) + " must be on or off, got 'yes'"),
                std::string::npos)
          << e.what();
    }
  }
}

TEST_P(FusedDetection, BadArgumentsAreTheSeparateKernelsClearErrors) {
  // The fused path runs the same argument checks as fast_crf, cull_cells and compact_keypoints:
  // a cell array too small, a FAST table too small, a list without a count buffer.
  const FusedBackend& b = GetParam();
  if (!test::backend_available(b.name)) GTEST_SKIP() << b.name << ": no device here (`portaslam backends` says why)";
  ScopedEnv groups(b.work_groups_env, "on");
  ScopedEnv fused(b.fused_env, "on");
  auto backend = BackendRegistry::instance().create(b.name, {});
  FrontendSettings settings;
  settings.levels = 1;
  const FrontendTables tables = FrontendTables::build(settings, 320, 240);
  const PyramidLayout layout = PyramidLayout::make(tables.level_sizes, 1);
  const PyramidLayout responses_layout = PyramidLayout::make(tables.level_sizes, 2);
  auto pyramid = backend->allocate(static_cast<std::size_t>(layout.total_bytes));
  auto responses = backend->allocate(static_cast<std::size_t>(responses_layout.total_bytes));
  auto lut = backend->allocate(65536), small_lut = backend->allocate(16);
  const auto cells_bytes = static_cast<std::size_t>(tables.cells.total_cells) * sizeof(Keypoint);
  auto cells = backend->allocate(cells_bytes), small_cells = backend->allocate(cells_bytes / 2);
  auto items = backend->allocate(cells_bytes), count = backend->allocate(4);
  const FastParams fast{settings.fast_threshold, settings.edge};
  const PfaParams pfa{tables.scales_q16, 320, 240, 3};
  const DeviceList list{items.get(), count.get(), 0, tables.cells.total_cells};
  const auto expect_error = [&](const char* needle, const auto& call) {
    try {
      call();
      ADD_FAILURE() << "no error; expected one naming '" << needle << "'";
    } catch (const BackendError& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  expect_error("cull_cells: the cell array", [&] {
    backend->detect_keypoints(*pyramid, layout, *lut, *responses, responses_layout, fast, tables.cells, *small_cells,
                              &pfa, list);
  });
  expect_error("fast_crf: the FAST table", [&] {
    backend->detect_keypoints(*pyramid, layout, *small_lut, *responses, responses_layout, fast, tables.cells, *cells,
                              &pfa, list);
  });
  expect_error("compact_keypoints: the list has no count buffer", [&] {
    backend->detect_keypoints(*pyramid, layout, *lut, *responses, responses_layout, fast, tables.cells, *cells, &pfa,
                              DeviceList{items.get(), nullptr, 0, tables.cells.total_cells});
  });
}

INSTANTIATE_TEST_SUITE_P(
    Backends, FusedDetection,
    ::testing::Values(FusedBackend{"opencl", "PORTA_OPENCL_WORK_GROUPS", "PORTA_OPENCL_FUSED_DETECT",
                                   "PORTA_OPENCL_PFA_IN_CULL", nullptr, "fast_cull_group",
                                   "pfa_compact_group", "fast_tiled", nullptr},
                      FusedBackend{"vulkan", "PORTA_VULKAN_WORK_GROUPS", "PORTA_VULKAN_FUSED_DETECT",
                                   "PORTA_VULKAN_PFA_IN_CULL", "PORTA_VULKAN_CULL_FINISHES", "fast_cull",
                                   "pfa_compact_group", "fast_tiled", "fast_cull_finish"}),
    [](const ::testing::TestParamInfo<FusedBackend>& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace porta
