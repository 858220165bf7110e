// Frames in flight (FrontendOptions::in_flight): submit/collect give the bytes of one frame at a
// time, on an in-order backend (cpu) and on a backend with several queues whose asynchronous
// downloads only land when their queue is finished (a cpu backend behind deferred transfers, as a
// GPU backend behaves), and misuse is a clear error.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <set>
#include <stdexcept>
#include <vector>

#include "cpu/cpu_backend.hpp"
#include "porta/frontend.hpp"
#include "support/test_images.hpp"

namespace porta {
namespace {

// Runs every kernel at once on the cpu backend, but answers like a backend of four queues: a
// download_async fills its destination with junk and only writes the real bytes (as they were when
// it was issued) when its queue is finished or everything is synchronized. A Frontend that reads
// results before finishing the right queue sees the junk.
class DeferredQueues final : public Backend {
 public:
  static constexpr int kQueues = 4;
  static constexpr std::uint8_t kJunk = 0xCD;

  std::string name() const override { return "deferred"; }
  std::string device_name() const override { return "cpu behind deferred downloads"; }
  std::unique_ptr<Buffer> allocate(std::size_t bytes) override { return cpu.allocate(bytes); }
  void upload(Buffer& d, std::size_t o, const void* s, std::size_t n) override { cpu.upload(d, o, s, n); }
  void download(const Buffer& s, std::size_t o, void* d, std::size_t n) override { cpu.download(s, o, d, n); }
  void fill(Buffer& d, std::size_t o, std::size_t n, std::uint8_t v) override { cpu.fill(d, o, n, v); }
  void synchronize() override {
    for (int q = 0; q < kQueues; ++q) land(q);
  }

  int queue_count() const override { return kQueues; }
  void use_queue(int queue) override {
    if (queue < 0 || queue >= kQueues) throw BackendError("deferred: bad queue " + std::to_string(queue));
    current = queue;
    used.insert(queue);
  }
  void queue_wait(int other) override { waits.emplace_back(current, other); }
  void finish_queue(int queue) override {
    ++finishes;
    land(queue);
  }
  void download_async(const Buffer& src, std::size_t src_offset, HostBuffer& dst, std::size_t dst_offset,
                      std::size_t bytes) override {
    Pending p{&dst, dst_offset, std::vector<std::uint8_t>(bytes)};
    cpu.download(src, src_offset, p.bytes.data(), bytes);
    std::memset(dst.data() + dst_offset, kJunk, bytes);
    pending[current].push_back(std::move(p));
  }

  void rectify(const Buffer& a, const Plane& b, const Buffer& c, Buffer& d, const Plane& e) override {
    cpu.rectify(a, b, c, d, e);
  }
  void build_pyramid(Buffer& a, const PyramidLayout& b, const Buffer& c, const std::vector<std::int32_t>& d) override {
    cpu.build_pyramid(a, b, c, d);
  }
  void fast_crf(const Buffer& a, const PyramidLayout& b, const Buffer& c, Buffer& d, const PyramidLayout& e,
                const FastParams& f) override {
    cpu.fast_crf(a, b, c, d, e, f);
  }
  void cull_cells(const Buffer& a, const PyramidLayout& b, const CellLayout& c, Buffer& d) override {
    cpu.cull_cells(a, b, c, d);
  }
  void pfa_filter(Buffer& a, const CellLayout& b, const PfaParams& c) override { cpu.pfa_filter(a, b, c); }
  void compact_keypoints(const Buffer& a, int b, DeviceList c) override { cpu.compact_keypoints(a, b, c); }
  void orient(const Buffer& a, const PyramidLayout& b, DeviceList c, const std::array<int, 16>& d, const Buffer& e,
              int f) override {
    cpu.orient(a, b, c, d, e, f);
  }
  void blur(const Buffer& a, const PyramidLayout& b, Buffer& c, const std::array<std::int32_t, 7>& d) override {
    cpu.blur(a, b, c, d);
  }
  void orb_describe(const Buffer& a, const PyramidLayout& b, ConstDeviceList c, const Buffer& d, Buffer& e) override {
    cpu.orb_describe(a, b, c, d, e);
  }
  void stereo_match(const Buffer& a, const Buffer& b, const PyramidLayout& c, ConstDeviceList d, const Buffer& e,
                    ConstDeviceList f, const Buffer& g, const StereoParams& h, Buffer& i) override {
    cpu.stereo_match(a, b, c, d, e, f, g, h, i);
  }
  void projection_match(ConstDeviceList a, const Buffer& b, const Buffer& c, const Buffer& d, int e,
                        const std::vector<std::int32_t>& f, Buffer& g) override {
    cpu.projection_match(a, b, c, d, e, f, g);
  }

  cpu::CpuBackend cpu{2};
  int current = 0;
  int finishes = 0;
  std::set<int> used;
  std::vector<std::pair<int, int>> waits;  // (waiting queue, queue waited for)

 private:
  struct Pending {
    HostBuffer* dst;
    std::size_t offset;
    std::vector<std::uint8_t> bytes;
  };
  void land(int queue) {
    for (Pending& p : pending[queue]) std::memcpy(p.dst->data() + p.offset, p.bytes.data(), p.bytes.size());
    pending[queue].clear();
  }
  std::map<int, std::vector<Pending>> pending;
};

void expect_same(const Features& want, const Features& got, const std::string& what) {
  ASSERT_EQ(want.keypoints.size(), got.keypoints.size()) << what;
  ASSERT_EQ(want.descriptors.size(), got.descriptors.size()) << what;
  // Element-wise (an empty vector's data() may be null, which memcmp must not get).
  EXPECT_TRUE(std::equal(want.keypoints.begin(), want.keypoints.end(), got.keypoints.begin(),
                         [](const Keypoint& a, const Keypoint& b) { return std::memcmp(&a, &b, sizeof a) == 0; }))
      << what << ": keypoints differ";
  EXPECT_TRUE(std::equal(want.descriptors.begin(), want.descriptors.end(), got.descriptors.begin(),
                         [](const Descriptor& a, const Descriptor& b) { return std::memcmp(&a, &b, sizeof a) == 0; }))
      << what << ": descriptors differ";
  EXPECT_EQ(want.keypoints_per_level, got.keypoints_per_level) << what;
}

void expect_same(const StereoFeatures& want, const StereoFeatures& got, const std::string& what) {
  expect_same(want.left, got.left, what + ", left");
  expect_same(want.right, got.right, what + ", right");
  ASSERT_EQ(want.matches.size(), got.matches.size()) << what;
  EXPECT_TRUE(std::equal(want.matches.begin(), want.matches.end(), got.matches.begin(),
                         [](const StereoMatch& a, const StereoMatch& b) { return std::memcmp(&a, &b, sizeof a) == 0; }))
      << what << ": matches differ";
}

struct Pairs {
  std::vector<Image> left, right;
};

// Five different pairs (different textures and shifts): a frame collected with another's results
// cannot pass for its own.
Pairs five_pairs(int w, int h) {
  Pairs p;
  for (int i = 0; i < 5; ++i) {
    p.left.push_back(test::textured_image(w, h, 100 + i));
    p.right.push_back(test::shifted_right(p.left.back(), -(6 + 3 * i)));
  }
  return p;
}

// Submits frames 0-2, then collects one and submits the next until all are in: three in flight.
std::vector<StereoFeatures> pipelined_stereo(Frontend& frontend, const Pairs& in) {
  std::vector<StereoFeatures> out;
  for (std::size_t i = 0; i < in.left.size(); ++i) {
    if (frontend.pending() == 3) out.push_back(frontend.collect_stereo());
    frontend.submit_stereo(in.left[i].view(), in.right[i].view());
  }
  while (frontend.pending() > 0) out.push_back(frontend.collect_stereo());
  return out;
}

TEST(FrontendInFlight, PipelinedStereoGivesTheBytesOfOneFrameAtATime) {
  const Pairs in = five_pairs(320, 240);
  FrontendSettings s;
  s.levels = 4;
  cpu::CpuBackend reference_backend(2);
  Frontend reference(reference_backend, s, 320, 240);
  std::vector<StereoFeatures> want;
  for (int i = 0; i < 5; ++i) want.push_back(reference.detect_stereo(in.left[i].view(), in.right[i].view()));
  ASSERT_GT(want[0].num_matches(), 20);

  FrontendOptions o;
  o.in_flight = 3;
  cpu::CpuBackend cpu_backend(2);
  Frontend on_cpu(cpu_backend, s, 320, 240, o);
  DeferredQueues deferred;
  Frontend on_queues(deferred, s, 320, 240, o);
  EXPECT_EQ(on_queues.in_flight(), 3);
  const auto got_cpu = pipelined_stereo(on_cpu, in);
  const auto got_queues = pipelined_stereo(on_queues, in);
  ASSERT_EQ(got_cpu.size(), 5u);
  ASSERT_EQ(got_queues.size(), 5u);
  for (int i = 0; i < 5; ++i) {
    expect_same(want[i], got_cpu[i], "cpu, frame " + std::to_string(i));
    expect_same(want[i], got_queues[i], "four queues, frame " + std::to_string(i));
  }
  // Slots 0 and 1 have queues of their own (0-1, 2-3), slot 2 shares slot 0's; left waits for right.
  EXPECT_EQ(deferred.used, (std::set<int>{0, 1, 2, 3}));
  ASSERT_EQ(deferred.waits.size(), 5u);
  EXPECT_EQ(deferred.waits[0], std::make_pair(0, 1));
  EXPECT_EQ(deferred.waits[1], std::make_pair(2, 3));
  EXPECT_EQ(on_queues.pending(), 0);
}

TEST(FrontendInFlight, TheSpareQueueIsOneNoSlotUses) {
  FrontendSettings s;
  s.levels = 2;
  DeferredQueues deferred;
  FrontendOptions one;
  Frontend single(deferred, s, 64, 48, one);
  EXPECT_EQ(single.spare_queue(), 2);  // the slot takes queues 0 and 1 of 4
  const Pairs in = five_pairs(64, 48);
  deferred.used.clear();
  single.submit_stereo(in.left[0].view(), in.right[0].view());
  single.collect_stereo();
  EXPECT_EQ(deferred.used.count(single.spare_queue()), 0u) << "a frame went to the spare queue";
  FrontendOptions two;
  two.in_flight = 2;
  EXPECT_EQ(Frontend(deferred, s, 64, 48, two).spare_queue(), -1);  // both slots take all four
  cpu::CpuBackend in_order(1);
  EXPECT_EQ(Frontend(in_order, s, 64, 48, one).spare_queue(), -1);  // one queue: nothing to spare
}

TEST(FrontendInFlight, PipelinedDetectionGivesTheBytesOfOneFrameAtATime) {
  const Pairs in = five_pairs(256, 200);
  for (const bool describe : {false, true}) {
    FrontendOptions one;
    one.describe = describe;
    FrontendOptions two = one;
    two.in_flight = 2;
    cpu::CpuBackend reference_backend(1);
    Frontend reference(reference_backend, FrontendSettings{}, 256, 200, one);
    DeferredQueues deferred;
    Frontend on_queues(deferred, FrontendSettings{}, 256, 200, two);
    on_queues.submit(in.left[0].view());
    for (int i = 0; i < 5; ++i) {
      if (i + 1 < 5) on_queues.submit(in.left[i + 1].view());
      EXPECT_EQ(on_queues.pending(), i + 1 < 5 ? 2 : 1);
      const Features got = on_queues.collect();
      expect_same(reference.detect(in.left[i].view()), got,
                  std::string(describe ? "detect + describe" : "detect") + ", frame " + std::to_string(i));
      EXPECT_GT(on_queues.last_times().total_ns, 0);
    }
  }
}

TEST(FrontendInFlight, InputImagesAreReadInPlaceAndGiveTheSameBytes) {
  const Pairs in = five_pairs(320, 240);
  cpu::CpuBackend reference_backend(2);
  Frontend reference(reference_backend, FrontendSettings{}, 320, 240);
  FrontendOptions o;
  o.in_flight = 3;
  DeferredQueues deferred;
  Frontend frontend(deferred, FrontendSettings{}, 320, 240, o);
  // A ring of three pinned pairs, refilled once its frame has been collected, as a camera would.
  std::vector<InputImage> left, right;
  for (int i = 0; i < 3; ++i) {
    left.push_back(frontend.make_input_image());
    right.push_back(frontend.make_input_image());
    EXPECT_EQ(left.back().width(), 320);
    EXPECT_GE(left.back().pitch_bytes(), 320);
  }
  std::vector<StereoFeatures> got;
  for (int i = 0; i < 5; ++i) {
    if (frontend.pending() == 3) got.push_back(frontend.collect_stereo());
    left[i % 3].assign(in.left[i].view());
    right[i % 3].assign(in.right[i].view());
    frontend.submit_stereo(left[i % 3], right[i % 3]);
  }
  while (frontend.pending() > 0) got.push_back(frontend.collect_stereo());
  ASSERT_EQ(got.size(), 5u);
  for (int i = 0; i < 5; ++i)
    expect_same(reference.detect_stereo(in.left[i].view(), in.right[i].view()), got[i],
                "input images, frame " + std::to_string(i));

  // Mono as well, and the input's own view reads back what was assigned.
  frontend.submit(left[0]);
  expect_same(reference.detect(left[0].view()), frontend.collect(), "mono input image");
  EXPECT_EQ(0, std::memcmp(left[0].view().row(17), in.left[3].view().row(17), 320));
}

TEST(FrontendInFlight, ForeignOrMisfitInputImagesAreRefused) {
  cpu::CpuBackend backend(1);
  Frontend a(backend, FrontendSettings{}, 128, 96);
  Frontend b(backend, FrontendSettings{}, 128, 96);
  InputImage mine = a.make_input_image();
  InputImage theirs = b.make_input_image();
  try {
    a.submit(theirs);
    FAIL() << "another Frontend's input image was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("not made by this Frontend"), std::string::npos) << e.what();
  }
  EXPECT_THROW(a.submit_stereo(mine, theirs), std::invalid_argument);
  InputImage moved = std::move(mine);
  EXPECT_THROW(a.submit(mine), std::invalid_argument);  // NOLINT(bugprone-use-after-move): the point
  EXPECT_EQ(a.pending(), 0);
  const Image small = test::textured_image(64, 48, 1);
  EXPECT_THROW(moved.assign(small.view()), std::invalid_argument);
  a.submit(moved);
  EXPECT_TRUE(a.collect().keypoints.empty()) << "a zero-filled input has no corners";
}

TEST(FrontendInFlight, MisuseIsAClearError) {
  cpu::CpuBackend backend(1);
  const Image img = test::textured_image(128, 96, 3);
  for (const int bad : {0, -1, FrontendOptions::kMaxInFlight + 1}) {
    FrontendOptions o;
    o.in_flight = bad;
    try {
      Frontend f(backend, FrontendSettings{}, 128, 96, o);
      FAIL() << "in_flight = " << bad << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("in_flight = " + std::to_string(bad)), std::string::npos) << e.what();
    }
  }

  FrontendOptions o;
  o.in_flight = 2;
  Frontend f(backend, FrontendSettings{}, 128, 96, o);
  auto message_of = [](auto&& call) {
    try {
      call();
    } catch (const std::logic_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message_of([&] { f.collect(); }).find("no frame in flight"), std::string::npos);
  f.submit(img.view());
  f.submit(img.view());
  EXPECT_NE(message_of([&] { f.submit(img.view()); }).find("2 frames are already in flight"), std::string::npos);
  EXPECT_NE(message_of([&] { f.detect(img.view()); }).find("wait to be collected"), std::string::npos);
  EXPECT_NE(message_of([&] { f.collect_stereo(); }).find("a single image (use collect)"), std::string::npos);
  EXPECT_EQ(f.pending(), 2) << "a refused call changes nothing";
  f.collect();
  f.collect();
  f.submit_stereo(img.view(), img.view());
  EXPECT_NE(message_of([&] { f.collect(); }).find("a stereo pair (use collect_stereo)"), std::string::npos);
  const StereoFeatures pair = f.collect_stereo();
  EXPECT_EQ(pair.left.keypoints.size(), f.detect(img.view()).keypoints.size());

  // A wrong image is refused before anything is enqueued.
  const Image small = test::textured_image(64, 48, 3);
  EXPECT_THROW(f.submit_stereo(img.view(), small.view()), std::invalid_argument);
  EXPECT_EQ(f.pending(), 0);

  // Destroying a Frontend with frames in flight waits for them (no crash, no leak under ASan).
  Frontend g(backend, FrontendSettings{}, 128, 96, o);
  g.submit(img.view());
}

}  // namespace
}  // namespace porta
