// Per-kernel device timing (BackendOptions::profile_kernels, Backend::kernel_times): the vulkan
// and opencl backends time every dispatch (timestamp queries, profiling events) and the host's
// work issuing it (with rows for transfers, queue waits and submissions), the totals name
// the frontend's kernels with the dispatch counts of a frame, reset starts them again, the timing
// changes no result byte, and a backend made without it reports nothing. Each backend runs where a
// device is (lavapipe and PoCL in CI); the test says so when it is not.
#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

#include "porta/frontend.hpp"
#include "porta/kernel_profile.hpp"
#include "porta/registry.hpp"
#include "support/backends.hpp"
#include "support/test_images.hpp"

namespace porta {
namespace {

std::unique_ptr<Backend> make(const std::string& name, bool profile) {
  BackendOptions options;
  options.profile_kernels = profile;
  return BackendRegistry::instance().create(name, options);
}

std::uint64_t dispatches(const std::vector<KernelTime>& times) {
  std::uint64_t n = 0;
  for (const KernelTime& t : times) n += t.dispatches;
  return n;
}

class KernelProfiling : public ::testing::TestWithParam<std::string> {};

TEST_P(KernelProfiling, TimesEveryDispatchOfAFrameWithoutChangingItsBytes) {
  const std::string name = GetParam();
  if (!test::backend_available(name)) GTEST_SKIP() << name << ": no device here (`portaslam backends` says why)";
  const Image left = test::textured_image(320, 240, 7), right = test::shifted_right(left, 6);
  auto profiled = make(name, true), plain = make(name, false);
  Frontend with(*profiled, FrontendSettings{}, 320, 240), without(*plain, FrontendSettings{}, 320, 240);

  const StereoFeatures a = with.detect_stereo(left.view(), right.view());
  const std::vector<KernelTime> first = profiled->kernel_times(true);
  ASSERT_FALSE(first.empty());
  double total_ms = 0.0, host_ms = 0.0;
  for (const KernelTime& t : first) {
    EXPECT_FALSE(t.kernel.empty());
    EXPECT_GE(t.dispatches, 1u) << t.kernel;
    EXPECT_GE(t.device_ms, 0.0) << t.kernel;
    EXPECT_GE(t.host_ms, 0.0) << t.kernel;
    total_ms += t.device_ms;
    host_ms += t.host_ms;
  }
  EXPECT_GT(total_ms, 0.0) << "a whole stereo frame took no device time";
  EXPECT_GT(host_ms, 0.0) << "issuing a whole stereo frame took the host no time";
  auto named = [&](const char* kernel) {
    for (const KernelTime& t : first)
      if (t.kernel == kernel) return t.dispatches;
    return std::uint64_t{0};
  };
  EXPECT_EQ(named("fast_crf"), 2u) << "one FAST pass per image of the pair";
  EXPECT_EQ(named("orb_describe"), 2u);
  // vulkan on a CPU device (lavapipe) runs the per-slot variant of the candidate search.
  EXPECT_EQ(named("stereo_match_candidates") + named("stereo_match_candidates_per_item"), 1u);
  // The host's own rows: opencl's transfers (each image uploaded once, its keypoints and
  // descriptors downloaded) and the left queue's wait for the right; vulkan's submissions.
  if (name == "opencl") {
    EXPECT_EQ(named("(upload_async)"), 2u);
    EXPECT_GE(named("(download_async)"), 4u);
    EXPECT_EQ(named("(queue_wait)"), 1u);
  } else {
    EXPECT_GE(named("(submit)"), 1u);
  }

  // Reset: nothing since; the same frame again dispatches the same kernels the same number of times.
  EXPECT_TRUE(profiled->kernel_times(false).empty());
  const StereoFeatures b = with.detect_stereo(left.view(), right.view());
  const std::vector<KernelTime> second = profiled->kernel_times(false);
  ASSERT_EQ(second.size(), first.size());
  for (std::size_t i = 0; i < first.size(); ++i) {
    EXPECT_EQ(second[i].kernel, first[i].kernel);
    EXPECT_EQ(second[i].dispatches, first[i].dispatches) << first[i].kernel;
  }
  // Without reset the totals keep adding up.
  with.detect_stereo(left.view(), right.view());
  EXPECT_EQ(dispatches(profiled->kernel_times(false)), 2 * dispatches(first));

  // The timing is not in the results.
  const StereoFeatures c = without.detect_stereo(left.view(), right.view());
  EXPECT_TRUE(plain->kernel_times(true).empty()) << "made without profile_kernels";
  for (const StereoFeatures* f : {&a, &b}) {
    ASSERT_EQ(f->left.keypoints.size(), c.left.keypoints.size());
    ASSERT_EQ(f->matches.size(), c.matches.size());
    EXPECT_EQ(std::memcmp(f->left.keypoints.data(), c.left.keypoints.data(),
                          c.left.keypoints.size() * sizeof(Keypoint)), 0);
    EXPECT_EQ(std::memcmp(f->left.descriptors.data(), c.left.descriptors.data(),
                          c.left.descriptors.size() * sizeof(Descriptor)), 0);
    EXPECT_EQ(std::memcmp(f->matches.data(), c.matches.data(), c.matches.size() * sizeof(c.matches[0])), 0);
  }
  EXPECT_GT(c.num_matches(), 10) << "the comparison covered real matches";
}

INSTANTIATE_TEST_SUITE_P(Backends, KernelProfiling, ::testing::Values("vulkan", "opencl"));

TEST(KernelProfile, SumsPerKernelInFirstDispatchOrderAndResets) {
  KernelProfile p;
  p.add("b", 1.0);
  p.add("a", 0.5);
  p.add("b", 2.0);
  const std::vector<KernelTime> t = p.take(false);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t[0].kernel, "b");
  EXPECT_EQ(t[0].dispatches, 2u);
  EXPECT_DOUBLE_EQ(t[0].device_ms, 3.0);
  EXPECT_EQ(t[1].kernel, "a");
  EXPECT_EQ(p.take(true).size(), 2u);
  EXPECT_TRUE(p.take(false).empty());
}

}  // namespace
}  // namespace porta
