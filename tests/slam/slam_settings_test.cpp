// SlamSettings helpers: the culling cell that fits the image size.
#if PORTA_SLAM_BUILT
#include <gtest/gtest.h>

#include "porta/slam/slam_settings.hpp"

namespace porta::slam {
namespace {

// sqrt(W * H / 455) rounded, in [8, 32]: KITTI keeps ORB-SLAM2-sized 32-px cells, half-size
// images get half-size cells, tiny and huge images stay within the bounds.
TEST(SlamSettings, DefaultCellSizeFollowsTheImageArea) {
  EXPECT_EQ(default_cell_size(1242, 375), 32);
  EXPECT_EQ(default_cell_size(2484, 750), 32);
  EXPECT_EQ(default_cell_size(640, 194), 17);
  EXPECT_EQ(default_cell_size(621, 188), 16);
  EXPECT_EQ(default_cell_size(752, 480), 28);
  EXPECT_EQ(default_cell_size(320, 240), 13);
  EXPECT_EQ(default_cell_size(64, 48), 8);
  EXPECT_EQ(default_cell_size(0, 0), 8);
}

}  // namespace
}  // namespace porta::slam
#endif  // PORTA_SLAM_BUILT
