// Quality on real data: pins what a correct frontend achieves on Oxford pairs (repeatability,
// descriptor matching) and Middlebury scenes (sparse stereo accuracy), so that a broken kernel
// shows up as a quality drop even where no hand-worked expectation reaches. The first tests check
// the measuring code itself on hand-worked points.
#include <gtest/gtest.h>

#include "cpu/cpu_backend.hpp"
#include "quality/experiments.hpp"
#include "quality/metrics.hpp"
#include "quality/quality_data.hpp"
#include "support/data_path.hpp"

namespace porta::quality {
namespace {

const cv::Size kFrame(100, 100);

cv::Matx33d translation(double dx, double dy) { return {1, 0, dx, 0, 1, dy, 0, 0, 1}; }

// H shifts by (+5, 0). Projections of the first image: (15,10) (25,20) (25.5,20) and (103,50),
// which falls outside the 100x100 second image. Candidates within 1.5 px: (0,0) at 0.5 px,
// (1,1) at 0 px, (2,1) at 0.5 px. Closest first: (1,1), then (0,0); (2,1) finds 1 taken.
// Common region: 3 of the first, both of the second; repeatability = 2 / min(3, 2) = 1.
TEST(QualityMetrics, Repeatability_PairsClosestFirstOneToOneInsideTheCommonRegion) {
  const std::vector<cv::Point2d> first = {{10, 10}, {20, 20}, {20.5, 20}, {98, 50}};
  const std::vector<cv::Point2d> second = {{15, 10.5}, {25, 20}};
  const Repeatability r = repeatability(first, kFrame, second, kFrame, translation(5, 0), 1.5);
  EXPECT_EQ(r.common_first, 3);
  EXPECT_EQ(r.common_second, 2);
  EXPECT_EQ(r.repeated, 2);
  EXPECT_DOUBLE_EQ(r.value, 1.0);
}

// H zooms out by 4: (40,40) lands on (10,10), 0.5 px from (10.5,10) in the second image, but
// (10.5,10) back-projects to (42,40), 2 px from (40,40) in the first: it repeats only in the
// one-sided measure.
TEST(QualityMetrics, Repeatability_SymmetricVariantNeedsEpsilonInBothImages) {
  const cv::Matx33d zoom_out(0.25, 0, 0, 0, 0.25, 0, 0, 0, 1);
  const Repeatability far = repeatability({{40, 40}}, kFrame, {{10.5, 10}}, kFrame, zoom_out, 1.5);
  EXPECT_DOUBLE_EQ(far.value, 1.0);
  EXPECT_DOUBLE_EQ(far.symmetric_value, 0.0);
  // (10.3,10) back-projects to (41.2,40), 1.2 px away: repeats in both.
  const Repeatability near = repeatability({{40, 40}}, kFrame, {{10.3, 10}}, kFrame, zoom_out, 1.5);
  EXPECT_DOUBLE_EQ(near.symmetric_value, 1.0);
}

// Rows as bytes: first a = 0x00.., b = 0xFF..; second c = 0x0F.. (4 bits from a per byte, 4
// from b), d = 0x00... a's nearest is d (0); b's nearest is c (128 < 256); c's nearest is a or
// b at 128 each: the tie goes to a, so (b, c) is not mutual. Only (a, d) is.
TEST(QualityMetrics, MutualHammingMatches_KeepOnlyMutualNearestWithTiesToLowerIndex) {
  cv::Mat first(2, 32, CV_8U), second(2, 32, CV_8U);
  first.row(0).setTo(0x00);
  first.row(1).setTo(0xFF);
  second.row(0).setTo(0x0F);
  second.row(1).setTo(0x00);
  const auto matches = mutual_hamming_matches(first, {0, 1}, second, {0, 1});
  ASSERT_EQ(matches.size(), 1u);
  EXPECT_EQ(matches[0], std::make_pair(0, 1));
}

TEST(QualityMetrics, MatchingScore_CountsCorrectMatchesOverCommonFirstKeypoints) {
  FeatureSet first, second;
  first.points = {{10, 10}, {50, 50}, {90, 90}};
  second.points = {{12, 10}, {80, 20}};
  first.descriptors = cv::Mat(3, 32, CV_8U);
  second.descriptors = cv::Mat(2, 32, CV_8U);
  first.descriptors.row(0).setTo(0x11);
  first.descriptors.row(1).setTo(0x77);
  first.descriptors.row(2).setTo(0x00);   // projects to (95, 90): outside the 92-wide second image
  second.descriptors.row(0).setTo(0x11);  // (10,10) -> (15,10): 3 px from (12,10), correct at 3
  second.descriptors.row(1).setTo(0x77);  // (50,50) -> (55,50): far from (80,20), wrong
  const MatchingScore m = matching_score(first, kFrame, second, {92, 100}, translation(5, 0), 3.0);
  EXPECT_EQ(m.common_first, 2);
  EXPECT_EQ(m.mutual_matches, 2);
  EXPECT_EQ(m.correct_matches, 1);
  EXPECT_DOUBLE_EQ(m.score, 0.5);
  EXPECT_DOUBLE_EQ(m.precision, 0.5);
}

// ---- Real data ---------------------------------------------------------------------------------

class QualityOnRealData : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { backend_ = std::make_unique<cpu::CpuBackend>(2); }
  static void TearDownTestSuite() { backend_.reset(); }

  static bool have(const std::string& relative, std::string& why) {
    if (!test::data_file(relative).empty()) return true;
    why = test::skip_reason(relative);
    return false;
  }

  static std::unique_ptr<cpu::CpuBackend> backend_;
};
std::unique_ptr<cpu::CpuBackend> QualityOnRealData::backend_;

// leuven's H1to5p is stored negated (h33 = -0.576); loaded, it is scaled to h33 = 1.
TEST_F(QualityOnRealData, LoadHomography_ReadsTheFirstMatrixNodeScaledToUnitH33) {
  std::string why;
  if (!have("oxford-affine/leuven/H1to5p.xml", why)) GTEST_SKIP() << why;
  const cv::Matx33d h = load_oxford_homography(test::data_dir(), "leuven", 5);
  EXPECT_DOUBLE_EQ(h(2, 2), 1.0);
  EXPECT_NEAR(h(0, 0), -5.7780461e-01 / -5.7604815e-01, 1e-12);
  EXPECT_NEAR(h(1, 2), 4.5205045e+00 / -5.7604815e-01, 1e-12);
}

TEST_F(QualityOnRealData, MiddleburyScale_IsReadFromScalesXml) {
  std::string why;
  if (!have("middlebury/scales.xml", why)) GTEST_SKIP() << why;
  EXPECT_EQ(load_middlebury_scale(test::data_dir(), "tsukuba"), 16);
  EXPECT_EQ(load_middlebury_scale(test::data_dir(), "venus"), 8);
  EXPECT_THROW(load_middlebury_scale(test::data_dir(), "no-such-scene"), DataError);
}

// The bounds below are the values porta_quality measured on the cpu backend (docs/QUALITY.md)
// with small margins. The frontend is integer-exact, so these numbers move only when its code
// does: a deliberate change re-measures them with porta_quality and updates this file and
// docs/QUALITY.md together. Checked to fail when one stage is broken on purpose (levels >= 1 of
// the pyramid shifted by 1 px, FAST threshold +15, PFA skipped, orientation left at bin 0, blur
// skipped, stereo disparities rounded to whole pixels).

struct OxfordBound {
  const char* set;
  int target;
  int img1_keypoints;         ///< ours bounded, expected within 5 %
  double min_repeatability;   ///< ours bounded, epsilon 1.5 px
  double min_matching_score;  ///< ours ORB, correct within 3 px
  double min_precision;
};

// Measured (img1 keypoints, repeatability, matching score, precision):
//   bikes 1-2 (blur):      1957, 0.381, 0.268, 0.721
//   ubc 1-2 (JPEG):        2177, 0.629, 0.579, 0.940
//   wall 1-2 (viewpoint):  3908, 0.268, 0.177, 0.544
//   bark 1-2 (zoom and rotation, so matching needs the orientation): 1634, 0.303, 0.141, 0.557
TEST_F(QualityOnRealData, Oxford_EasyPairsKeepTheirRepeatabilityAndMatchingScore) {
  const OxfordBound bounds[] = {
      {"bikes", 2, 1957, 0.36, 0.25, 0.69},
      {"ubc", 2, 2177, 0.60, 0.55, 0.91},
      {"wall", 2, 3908, 0.25, 0.165, 0.52},
      {"bark", 2, 1634, 0.285, 0.13, 0.53},
  };
  OxfordEvaluator evaluator(*backend_, FrontendSettings{});
  for (const auto& b : bounds) {
    std::string why;
    if (!have(std::string("oxford-affine/") + b.set + "/img1.png", why)) GTEST_SKIP() << why;
    SCOPED_TRACE(std::string(b.set) + " 1-" + std::to_string(b.target));
    const OxfordPairResult r = evaluator.evaluate_pair(test::data_dir(), b.set, b.target);
    EXPECT_NEAR(r.count_first[kOursBounded], b.img1_keypoints, 0.05 * b.img1_keypoints);
    EXPECT_GT(r.repeatability[kOursBounded].value, b.min_repeatability);
    EXPECT_GT(r.ours_matching.score, b.min_matching_score);
    EXPECT_GT(r.ours_matching.precision, b.min_precision);
  }
}

struct StereoBound {
  const char* scene;
  int matches;  ///< expected within 7 %
  double min_within_1px;
  double min_within_half_px;
};

// Measured with disparities 0..64: tsukuba 219 matches of 393 left keypoints, within 1 px 0.790,
// within 0.5 px 0.548; venus 254 of 467, 0.878, 0.630; all but one venus disparity sub-pixel.
TEST_F(QualityOnRealData, Middlebury_StereoMatchesAreDenseAndAccurate) {
  const StereoBound bounds[] = {
      {"tsukuba", 219, 0.76, 0.52},
      {"venus", 254, 0.85, 0.60},
  };
  const FrontendSettings settings = middlebury_settings(FrontendSettings{}, 64);
  for (const auto& b : bounds) {
    std::string why;
    if (!have(std::string("middlebury/") + b.scene + "/disp2.png", why)) GTEST_SKIP() << why;
    SCOPED_TRACE(b.scene);
    const StereoSceneResult r = evaluate_stereo_scene(*backend_, settings, test::data_dir(), b.scene);
    const StereoAccuracy& a = r.accuracy;
    EXPECT_NEAR(a.matches, b.matches, 0.07 * b.matches);
    EXPECT_EQ(a.evaluated, a.matches);  // keypoints keep 19 px off the border, where truth is unknown
    EXPECT_GT(a.fraction_within_1px, b.min_within_1px);
    EXPECT_GT(a.fraction_within_half_px, b.min_within_half_px);
    EXPECT_GT(a.fractional_disparities, 0.9 * a.matches);  // the sub-pixel refinement ran
  }
}

}  // namespace
}  // namespace porta::quality
