// The pipelined System (system.hpp: submit / track_next with frames in flight) against the
// sequential one (process): on a rendered drive, in the deterministic mode, both give the same
// trajectory and keyframes bit for bit, also with the pairs in the System's input images; and the
// misuses of the pipeline are refused.
#if PORTA_RENDER_BUILT && PORTA_SLAM_BUILT

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "porta/registry.hpp"
#include "porta/slam/render/rasterizer.hpp"
#include "porta/slam/render/sequence.hpp"
#include "porta/slam/system.hpp"

namespace porta::slam {
namespace {

struct Drive {
  StereoCamera camera;
  std::vector<StereoPair> pairs;
};

/// The first frames of the built-in street loop at 480x146 (rendered once for every test).
const Drive& drive() {
  static const Drive d = [] {
    render::RenderOptions options;
    options.builtin = render::BuiltinPath::street_loop;
    options.width = 480;
    options.height = 146;
    options.count = 18;
    options.texture_size = 256;
    options.threads = 2;
    const render::SequencePlan plan = render::plan_sequence(options);
    Drive out;
    out.camera = plan.camera;
    render::Rasterizer rasterizer;
    for (std::size_t k = 0; k < plan.frames.size(); ++k) {
      render::StereoFrame frame = render::render_frame(plan, k, rasterizer);
      out.pairs.push_back({k, plan.frames[k].time_s, std::move(frame.left), std::move(frame.right)});
    }
    return out;
  }();
  return d;
}

SlamSettings settings_for(const StereoCamera& camera) {
  SlamSettings s;
  s.camera = camera;
  const int cell = default_cell_size(camera.width, camera.height);
  s.frontend.cell_width = s.frontend.cell_height = cell;
  s.frontend.stereo_max_disparity =
      std::clamp(static_cast<int>(std::ceil(camera.bf() / 0.5)), s.frontend.stereo_min_disparity + 1, camera.width);
  return s;
}

bool same(const Trajectory& a, const Trajectory& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a.poses[i].time_s != b.poses[i].time_s) return false;
    if (!(a.poses[i].pose.matrix().array() == b.poses[i].pose.matrix().array()).all()) return false;
  }
  return true;
}

/// The drive through process(), one pair at a time: what every pipelined run must give.
struct Sequential {
  Trajectory trajectory, keyframes;
  std::vector<TrackingState> states;
};

const Sequential& sequential() {
  static const Sequential s = [] {
    const Drive& d = drive();
    std::unique_ptr<Backend> backend = BackendRegistry::instance().create("cpu", {});
    System system(settings_for(d.camera), *backend, RunMode::deterministic);
    Sequential out;
    for (const StereoPair& pair : d.pairs) out.states.push_back(system.process(pair).state);
    system.finish();
    out.trajectory = system.trajectory();
    out.keyframes = system.keyframe_trajectory();
    return out;
  }();
  return s;
}

TEST(SystemPipeline, FramesInFlightGiveTheSequentialTrajectoryBitForBit) {
  const Drive& d = drive();
  std::unique_ptr<Backend> backend = BackendRegistry::instance().create("cpu", {});
  const Sequential& reference = sequential();
  ASSERT_EQ(reference.trajectory.size(), d.pairs.size()) << "every frame of the drive must be tracked";
  ASSERT_GE(reference.keyframes.size(), 3u);

  for (const int in_flight : {2, 3}) {
    SystemOptions options;
    options.frontend_in_flight = in_flight;
    System pipelined(settings_for(d.camera), *backend, RunMode::deterministic, options);
    std::size_t submitted = 0;
    for (std::size_t tracked = 0; tracked < d.pairs.size(); ++tracked) {
      while (submitted < d.pairs.size() && pipelined.pending() < static_cast<std::size_t>(in_flight))
        pipelined.submit(d.pairs[submitted++]);
      const TrackingResult result = pipelined.track_next();
      EXPECT_EQ(result.state, reference.states[tracked]) << "frame " << tracked;
    }
    pipelined.finish();
    EXPECT_TRUE(same(pipelined.trajectory(), reference.trajectory)) << in_flight << " frames in flight";
    EXPECT_TRUE(same(pipelined.keyframe_trajectory(), reference.keyframes)) << in_flight;
    ASSERT_EQ(pipelined.frame_times().size(), d.pairs.size());
    for (const FrameTimes& t : pipelined.frame_times()) {
      EXPECT_GT(t.frontend_ns, 0);
      EXPECT_GE(t.total_ns, t.frontend_ns + t.tracking_ns);
    }
  }
}

// The pairs in the System's input images (read in place, no copy on submit), a ring of them
// reused once their pair is tracked, as `portaslam run` does: the same bits as process().
TEST(SystemPipeline, InputImagesGiveTheSequentialTrajectoryBitForBit) {
  const Drive& d = drive();
  std::unique_ptr<Backend> backend = BackendRegistry::instance().create("cpu", {});
  const Sequential& reference = sequential();
  SystemOptions options;
  options.frontend_in_flight = 2;
  System pipelined(settings_for(d.camera), *backend, RunMode::deterministic, options);
  std::vector<StereoInput> ring(3);
  for (StereoInput& input : ring) {
    input.left = pipelined.make_input_image();
    input.right = pipelined.make_input_image();
    ASSERT_EQ(input.left.width(), d.camera.width);
    ASSERT_EQ(input.left.height(), d.camera.height);
  }
  const auto submit = [&](std::size_t k) {
    StereoInput& input = ring[k % ring.size()];
    input.index = d.pairs[k].index;
    input.time_s = d.pairs[k].time_s;
    input.left.assign(d.pairs[k].left.view());
    input.right.assign(d.pairs[k].right.view());
    pipelined.submit(input);
  };
  submit(0);
  for (std::size_t k = 0; k < d.pairs.size(); ++k) {
    if (k + 1 < d.pairs.size()) submit(k + 1);  // into the image pair k - 2 had
    const TrackingResult result = pipelined.track_next();
    EXPECT_EQ(result.state, reference.states[k]) << "frame " << k;
  }
  pipelined.finish();
  EXPECT_TRUE(same(pipelined.trajectory(), reference.trajectory));
  EXPECT_TRUE(same(pipelined.keyframe_trajectory(), reference.keyframes));
}

TEST(SystemPipeline, MisusesAreRefused) {
  const Drive& d = drive();
  std::unique_ptr<Backend> backend = BackendRegistry::instance().create("cpu", {});
  SystemOptions bad;
  bad.frontend_in_flight = 0;
  EXPECT_THROW(System(settings_for(d.camera), *backend, RunMode::deterministic, bad), std::invalid_argument);
  bad.frontend_in_flight = FrontendOptions::kMaxInFlight + 1;
  EXPECT_THROW(System(settings_for(d.camera), *backend, RunMode::deterministic, bad), std::invalid_argument);

  SystemOptions two;
  two.frontend_in_flight = 2;
  System system(settings_for(d.camera), *backend, RunMode::deterministic, two);
  EXPECT_THROW(system.track_next(), std::logic_error);  // nothing submitted
  system.submit(d.pairs[0]);
  EXPECT_THROW(system.process(d.pairs[1]), std::logic_error);  // a pair is pending
  system.submit(d.pairs[1]);
  EXPECT_THROW(system.submit(d.pairs[2]), std::logic_error);  // two in flight already
  StereoPair small{2, 0.2, Image(64, 32), Image(64, 32)};
  EXPECT_THROW(system.submit(small), std::invalid_argument);
  EXPECT_EQ(system.pending(), 2u);
  system.track_next();
  // Input images another System made, or one moved from, are refused naming the side.
  System other(settings_for(d.camera), *backend, RunMode::deterministic, two);
  StereoInput foreign{2, 0.2, other.make_input_image(), system.make_input_image()};
  try {
    system.submit(foreign);
    ADD_FAILURE() << "an input image of another System was taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("left input image was not made by this Frontend"), std::string::npos)
        << e.what();
  }
  StereoInput mine{2, 0.2, system.make_input_image(), system.make_input_image()};
  InputImage taken = std::move(mine.right);
  EXPECT_THROW(system.submit(mine), std::invalid_argument);  // the right image was moved from
  EXPECT_EQ(system.pending(), 1u);
  system.submit(d.pairs[1]);
  system.track_next();
  system.track_next();
  EXPECT_EQ(system.pending(), 0u);
  system.finish();
  EXPECT_THROW(system.submit(d.pairs[2]), std::logic_error);
}

}  // namespace
}  // namespace porta::slam

#endif  // PORTA_RENDER_BUILT && PORTA_SLAM_BUILT
