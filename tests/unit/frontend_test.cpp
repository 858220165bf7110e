// The whole cpu pipeline through porta::Frontend: order, determinism, and stereo on a known shift.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>

#include "cpu/cpu_backend.hpp"
#include "porta/frontend.hpp"
#include "support/test_images.hpp"

namespace porta {
namespace {

bool same_bytes(const Features& a, const Features& b) {
  return a.keypoints.size() == b.keypoints.size() && a.descriptors.size() == b.descriptors.size() &&
         std::memcmp(a.keypoints.data(), b.keypoints.data(), a.keypoints.size() * sizeof(Keypoint)) == 0 &&
         std::memcmp(a.descriptors.data(), b.descriptors.data(), a.descriptors.size() * sizeof(Descriptor)) == 0;
}

TEST(Frontend, KeypointsComeInCanonicalOrderOnePerCellAtMost) {
  cpu::CpuBackend backend(2);
  const Image img = test::textured_image(640, 480, 7);
  Frontend frontend(backend, FrontendSettings{}, img.width(), img.height());
  const Features f = frontend.detect(img.view());
  ASSERT_GT(f.keypoints.size(), 200u);
  ASSERT_EQ(f.descriptors.size(), f.keypoints.size());
  const auto& cells = frontend.tables().cells;
  int previous_cell = -1;
  for (const auto& k : f.keypoints) {
    const LevelCells& lc = cells.levels[k.level];
    const int cell = lc.first_cell + (k.y / lc.cell_h) * lc.cols + k.x / lc.cell_w;
    EXPECT_GT(cell, previous_cell) << "keypoints out of canonical order or two in one cell";
    previous_cell = cell;
    EXPECT_GT(k.response, 0);
    EXPECT_LT(k.angle_bin, 32);
    const Plane& p = frontend.pyramid_layout().levels[k.level];
    EXPECT_GE(k.x, 19);
    EXPECT_LT(k.x, p.width - 19);
  }
  int total = 0;
  for (int n : f.keypoints_per_level) total += n;
  EXPECT_EQ(total, static_cast<int>(f.keypoints.size()));
  EXPECT_GT(f.keypoints_per_level[7], 0) << "every level of a textured image has features";
}

TEST(Frontend, SameBytesAcrossRunsThreadCountsAndInputPitch) {
  const Image img = test::textured_image(333, 257, 11);
  const Image padded = Image::copy_of(img.view(), 401);
  FrontendSettings s;
  s.levels = 4;
  s.cell_width = 16;
  s.cell_height = 24;
  cpu::CpuBackend one(1), two(2);
  Frontend f1(one, s, img.width(), img.height());
  Frontend f2(two, s, img.width(), img.height());
  const Features a = f1.detect(img.view());
  const Features b = f1.detect(img.view());
  const Features c = f2.detect(padded.view());
  EXPECT_TRUE(same_bytes(a, b));
  EXPECT_TRUE(same_bytes(a, c));
  ASSERT_GT(a.keypoints.size(), 50u);
}

TEST(Frontend, PfaOnlyRemovesKeypoints) {
  cpu::CpuBackend backend(2);
  const Image img = test::textured_image(400, 300, 3);
  FrontendSettings on, off;
  off.pfa = false;
  Frontend fon(backend, on, img.width(), img.height());
  Frontend foff(backend, off, img.width(), img.height());
  const Features a = fon.detect(img.view());
  const Features b = foff.detect(img.view());
  EXPECT_LT(a.keypoints.size(), b.keypoints.size());
  // Every survivor of PFA is a keypoint of the unfiltered run, with the same descriptor.
  std::size_t j = 0;
  for (std::size_t i = 0; i < a.keypoints.size(); ++i) {
    while (j < b.keypoints.size() && std::memcmp(&b.keypoints[j], &a.keypoints[i], sizeof(Keypoint)) != 0) ++j;
    ASSERT_LT(j, b.keypoints.size()) << "PFA output " << i << " is not in the unfiltered list";
    EXPECT_EQ(std::memcmp(&a.descriptors[i], &b.descriptors[j], sizeof(Descriptor)), 0);
  }
}

TEST(Frontend, TinyAndFlatImagesGiveNoKeypointsAndNoCrash) {
  cpu::CpuBackend backend(2);
  for (auto [w, h] : {std::pair{1, 1}, std::pair{2, 3}, std::pair{38, 38}, std::pair{39, 39}}) {
    const Image img = test::random_image(w, h, 5);
    FrontendSettings s;
    s.levels = 12;
    Frontend frontend(backend, s, w, h);
    const Features f = frontend.detect(img.view());
    if (w < 39) {
      EXPECT_TRUE(f.keypoints.empty()) << w << "x" << h;
    }
    const StereoFeatures sf = frontend.detect_stereo(img.view(), img.view());
    EXPECT_EQ(sf.matches.size(), sf.left.keypoints.size());
  }
  const Image flat = test::flat_image(320, 240, 128);
  Frontend frontend(backend, FrontendSettings{}, 320, 240);
  EXPECT_TRUE(frontend.detect(flat.view()).keypoints.empty());
}

TEST(Frontend, StereoRecoversAKnownIntegerShift) {
  cpu::CpuBackend backend(2);
  const Image left = test::textured_image(640, 480, 21);
  const int disparity = 12;
  const Image right = test::shifted_right(left, -disparity);  // right sees the scene shifted left
  Frontend frontend(backend, FrontendSettings{}, left.width(), left.height());
  const StereoFeatures s = frontend.detect_stereo(left.view(), right.view());
  ASSERT_GT(s.left.keypoints.size(), 300u);
  const int matched = s.num_matches();
  EXPECT_GT(matched, static_cast<int>(s.left.keypoints.size()) / 2);
  // The SAD parabola is biased even at an exact shift (as in ORB-SLAM2), and a level-n match is
  // only as fine as a level-n pixel: every match must be within one pixel of its level, and the
  // level-0 ones within half a pixel.
  for (std::size_t i = 0; i < s.matches.size(); ++i) {
    const auto& m = s.matches[i];
    if (m.disparity_q8 < 0) continue;
    const int level = s.left.keypoints[i].level;
    const int error_q8 = std::abs(m.disparity_q8 - disparity * 256);
    EXPECT_LE(error_q8, frontend.tables().scales_q16[level] >> 8) << "keypoint " << i << " level " << level;
    if (level == 0) {
      EXPECT_LE(error_q8, 128) << "keypoint " << i;
    }
  }
}

}  // namespace
}  // namespace porta
