// SlamSettings helpers: the culling cell that fits the image size, the defaults for a camera.
#if PORTA_SLAM_BUILT
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <thread>

#include "porta/slam/slam_settings.hpp"

namespace porta::slam {
namespace {

// sqrt(W * H / 594) rounded, in [8, 32]: KITTI gets 28-px cells, half-size images half-size
// cells, tiny and huge images stay within the bounds.
TEST(SlamSettings, DefaultCellSizeFollowsTheImageArea) {
  EXPECT_EQ(default_cell_size(1242, 375), 28);
  EXPECT_EQ(default_cell_size(2484, 750), 32);
  EXPECT_EQ(default_cell_size(640, 194), 14);
  EXPECT_EQ(default_cell_size(621, 188), 14);
  EXPECT_EQ(default_cell_size(752, 480), 25);
  EXPECT_EQ(default_cell_size(320, 240), 11);
  EXPECT_EQ(default_cell_size(64, 48), 8);
  EXPECT_EQ(default_cell_size(0, 0), 8);
}

// KITTI's camera: 28-px cells, disparities up to bf / 0.5 m = 772.1 -> 773 px (under the width);
// a 320x240 camera with a long focal length and baseline is capped at its width.
TEST(SlamSettings, DefaultSettingsFitTheCamera) {
  StereoCamera kitti{1242, 375, 718.856, 718.856, 607.19, 185.22, 0.537};
  const SlamSettings a = default_settings(kitti);
  EXPECT_EQ(a.frontend.cell_width, 28);
  EXPECT_EQ(a.frontend.cell_height, 28);
  EXPECT_EQ(a.frontend.stereo_max_disparity, 773);
  EXPECT_EQ(a.camera.fx, kitti.fx);
  EXPECT_NO_THROW(a.validate());

  StereoCamera small{320, 240, 400.0, 400.0, 160.0, 120.0, 1.0};
  const SlamSettings b = default_settings(small);
  EXPECT_EQ(b.frontend.cell_width, 11);
  EXPECT_EQ(b.frontend.stereo_max_disparity, 320);
  EXPECT_NO_THROW(b.validate());
}

// 0 leaves the count to the machine (1 on a small one, whose cores the frontend needs); a count
// outside [0, 64] is refused with the setting named.
TEST(SlamSettings, MappingThreadsAreResolvedAndBounded) {
  StereoCamera kitti{1242, 375, 718.856, 718.856, 607.19, 185.22, 0.537};
  SlamSettings s = default_settings(kitti);
  const int resolved = s.resolved_mapping_threads();
  EXPECT_GE(resolved, 1);
  EXPECT_LE(resolved, 8);
  if (std::thread::hardware_concurrency() < 8) {
    EXPECT_EQ(resolved, 1);
  }
  s.mapping_threads = 5;
  EXPECT_EQ(s.resolved_mapping_threads(), 5);
  EXPECT_NO_THROW(s.validate());
  for (const int bad : {-1, SlamSettings::kMaxMappingThreads + 1}) {
    s.mapping_threads = bad;
    try {
      s.validate();
      ADD_FAILURE() << "mapping_threads " << bad << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("mapping_threads"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace porta::slam
#endif  // PORTA_SLAM_BUILT
