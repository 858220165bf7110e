// porta_cuda_ablation: the CUDA backend's measurements for the paper's Tables I and II and the
// frame-rate targets, on a bare GPU machine (no OpenCV; synthetic textured images, or a binary
// PGM with --pgm).
//
//   --mode cull    times the culling kernel alone (launch_cull_cells) for each variant (mlpt_tewa,
//                  mlpt_block, log2_block) at 1242x375 and 640x480, 8 levels, cells 32 and 16:
//                  per-launch device time from CUDA events around each of --reps launches
//                  (median, p10, p90) and the mean of --reps back-to-back launches; checks that
//                  every variant writes the same cells as the cpu backend.
//   --mode frames  times whole frames through porta::Frontend on cuda: detect_stereo at 1242x375,
//                  8 levels (detect + extract + stereo, transfers included) and detect only at
//                  320x240, 1 level, for graphs on/off x streams on/off; --frames timed frames
//                  after --warmup; wall clock per frame (median, p10, p90) and frames per second
//                  over the whole run; checks that every configuration returns the same bytes
//                  (and the cpu backend's, for the first input).
//   --mode all     both (default).
// Prints tables, then one JSON object (also written to --json FILE).
//
//   porta_cuda_ablation [--mode cull|frames|all] [--variant NAME] [--reps N] [--frames N]
//                       [--warmup N] [--inputs N] [--pgm FILE] [--json FILE] [--no-cpu-check]
//                       [--profile-once]
// --profile-once: cull mode only, one untimed launch of the culling kernel per (size, cell,
// variant) in the printed order, so that `ncu` (bench/cuda/ablation.sh) profiles exactly those.
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "cuda/cuda_backend.hpp"
#include "cuda/cuda_errors.hpp"
#include "cuda/cull_plan.hpp"
#include "cuda/kernels.hpp"
#include "porta/frontend.hpp"
#include "porta/image.hpp"
#include "porta/registry.hpp"
#include "porta/tables.hpp"

namespace {

using porta::cuda::check;

struct Options {
  std::string mode = "all";
  std::string variant;  // empty: all
  int reps = 500;
  int frames = 1000;
  int warmup = 100;
  int inputs = 4;
  std::string pgm;
  std::string json;
  bool cpu_check = true;
  bool profile_once = false;  // cull: one launch per case, untimed (for ncu)
};

[[noreturn]] void usage(const std::string& why) {
  std::cerr << "porta_cuda_ablation: " << why << "\n"
            << "usage: porta_cuda_ablation [--mode cull|frames|all] [--variant mlpt_tewa|mlpt_block|log2_block]\n"
            << "         [--reps N] [--frames N] [--warmup N] [--inputs N] [--pgm FILE] [--json FILE]\n"
            << "         [--no-cpu-check] [--profile-once]\n"
            << "--profile-once (cull mode): one untimed launch per case, for Nsight Compute (bench/cuda/ablation.sh)\n";
  std::exit(2);
}

int to_int(const std::string& flag, const std::string& text, int min) {
  try {
    std::size_t used = 0;
    const int v = std::stoi(text, &used);
    if (used == text.size() && v >= min) return v;
  } catch (const std::exception&) {
  }
  usage(flag + " wants an integer >= " + std::to_string(min) + ", got '" + text + "'");
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) usage(a + " needs a value");
      return argv[++i];
    };
    if (a == "--mode") {
      o.mode = value();
      if (o.mode != "cull" && o.mode != "frames" && o.mode != "all") usage("unknown mode " + o.mode);
    } else if (a == "--variant") {
      o.variant = value();
      porta::cuda::parse_cull_variant(o.variant);  // throws on a bad name
    } else if (a == "--reps") {
      o.reps = to_int(a, value(), 1);
    } else if (a == "--frames") {
      o.frames = to_int(a, value(), 1);
    } else if (a == "--warmup") {
      o.warmup = to_int(a, value(), 0);
    } else if (a == "--inputs") {
      o.inputs = to_int(a, value(), 1);
    } else if (a == "--pgm") {
      o.pgm = value();
    } else if (a == "--json") {
      o.json = value();
    } else if (a == "--no-cpu-check") {
      o.cpu_check = false;
    } else if (a == "--profile-once") {
      o.profile_once = true;
    } else if (a == "--help" || a == "-h") {
      usage("help");
    } else {
      usage("unknown argument " + a);
    }
  }
  return o;
}

// ---- Inputs ----------------------------------------------------------------------------------------

struct Rng {
  std::uint64_t s;
  std::uint32_t next() {
    s = s * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<std::uint32_t>(s >> 33);
  }
  int range(int lo, int hi) { return lo + static_cast<int>(next() % static_cast<std::uint32_t>(hi - lo + 1)); }
};

/// A textured scene `width + margin` wide: smooth value noise, many filled rectangles and discs
/// (corners and blobs at all scales), fine noise. Deterministic in `seed`.
porta::Image synthetic_scene(int width, int height, std::uint64_t seed) {
  Rng rng{seed * 0x9E3779B97F4A7C15ull + 1};
  porta::Image img(width, height);
  std::vector<int> acc(static_cast<std::size_t>(width) * height, 0);
  for (int cell : {64, 16}) {
    const int gw = width / cell + 2, gh = height / cell + 2;
    std::vector<int> grid(static_cast<std::size_t>(gw) * gh);
    for (int& g : grid) g = rng.range(-40, 40);
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        const int gx = x / cell, gy = y / cell, fx = x % cell, fy = y % cell;
        auto at = [&](int i, int j) { return grid[static_cast<std::size_t>(j) * gw + i]; };
        const int top = at(gx, gy) * (cell - fx) + at(gx + 1, gy) * fx;
        const int bottom = at(gx, gy + 1) * (cell - fx) + at(gx + 1, gy + 1) * fx;
        acc[static_cast<std::size_t>(y) * width + x] += (top * (cell - fy) + bottom * fy) / (cell * cell);
      }
  }
  std::vector<std::uint8_t> base(acc.size());
  for (std::size_t i = 0; i < acc.size(); ++i) base[i] = static_cast<std::uint8_t>(std::clamp(128 + acc[i], 0, 255));
  const int shapes = width * height / 900;
  for (int k = 0; k < shapes; ++k) {
    const int w = rng.range(3, 40), h = rng.range(3, 40);
    const int x0 = rng.range(-10, width), y0 = rng.range(-10, height);
    const int v = rng.range(0, 255);
    const bool disc = rng.next() % 3 == 0;
    for (int y = std::max(0, y0); y < std::min(height, y0 + h); ++y)
      for (int x = std::max(0, x0); x < std::min(width, x0 + w); ++x) {
        if (disc) {
          const int dx = 2 * (x - x0) - w, dy = 2 * (y - y0) - h;
          if (dx * dx * h * h + dy * dy * w * w > w * w * h * h) continue;
        }
        base[static_cast<std::size_t>(y) * width + x] = static_cast<std::uint8_t>(v);
      }
  }
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const int n = static_cast<int>(rng.next() % 7) - 3;
      img.at(x, y) = static_cast<std::uint8_t>(std::clamp(base[static_cast<std::size_t>(y) * width + x] + n, 0, 255));
    }
  return img;
}

/// Reads a binary PGM (P5, maxval <= 255).
porta::Image read_pgm(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open " + path);
  std::string magic;
  in >> magic;
  if (magic != "P5") throw std::runtime_error(path + ": not a binary PGM (P5)");
  auto number = [&]() {
    in >> std::ws;
    while (in.peek() == '#') {
      std::string comment;
      std::getline(in, comment);
      in >> std::ws;
    }
    int v = 0;
    in >> v;
    return v;
  };
  const int w = number(), h = number(), maxval = number();
  in.get();
  if (w <= 0 || h <= 0 || maxval <= 0 || maxval > 255) throw std::runtime_error(path + ": unsupported PGM");
  porta::Image img(w, h);
  in.read(reinterpret_cast<char*>(img.data()), static_cast<std::streamsize>(img.size_bytes()));
  if (!in) throw std::runtime_error(path + ": truncated");
  return img;
}

/// `src` tiled (mirrored) over width x height, starting at column `shift`.
porta::Image tile_to(const porta::Image& src, int width, int height, int shift) {
  porta::Image out(width, height);
  auto mirror = [](int v, int n) {
    const int period = 2 * n;
    v %= period;
    if (v < 0) v += period;
    return v < n ? v : period - 1 - v;
  };
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      out.at(x, y) = src.at(mirror(x + shift, src.width()), mirror(y, src.height()));
  return out;
}

struct Pair {
  porta::Image left, right;
};

/// Rectified pairs with disparity 14 everywhere (x_left - x_right = 14).
std::vector<Pair> make_inputs(int width, int height, int count, const porta::Image* pgm) {
  constexpr int kDisparity = 14;
  std::vector<Pair> pairs;
  for (int i = 0; i < count; ++i) {
    porta::Image scene = pgm ? tile_to(*pgm, width + kDisparity, height, 37 * i)
                             : synthetic_scene(width + kDisparity, height, static_cast<std::uint64_t>(i + 1));
    Pair p{porta::Image(width, height), porta::Image(width, height)};
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        p.left.at(x, y) = scene.at(x, y);  // a scene point at left column x is at x - 14 on the right
        p.right.at(x, y) = scene.at(x + kDisparity, y);
      }
    pairs.push_back(std::move(p));
  }
  return pairs;
}

// ---- Statistics ------------------------------------------------------------------------------------

struct Summary {
  double median = 0, p10 = 0, p90 = 0, mean = 0;
};

Summary summarize(std::vector<double> v) {
  Summary s;
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  auto q = [&](double f) {
    const double pos = f * static_cast<double>(v.size() - 1);
    const auto lo = static_cast<std::size_t>(pos);
    const std::size_t hi = std::min(lo + 1, v.size() - 1);
    return v[lo] + (v[hi] - v[lo]) * (pos - static_cast<double>(lo));
  };
  s.median = q(0.5);
  s.p10 = q(0.1);
  s.p90 = q(0.9);
  double sum = 0;
  for (double x : v) sum += x;
  s.mean = sum / static_cast<double>(v.size());
  return s;
}

std::string fmt(double v, int decimals = 2) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// ---- Culling ablation --------------------------------------------------------------------------

struct CullRow {
  int width, height, levels, cell;
  std::string variant;
  int blocks, threads_per_block, total_cells;
  Summary us;             // per launch, events around each
  double back_to_back_us;  // mean of reps launches between two events
  bool same_as_cpu;
  bool same_as_first_variant;
};

/// Level-0 image -> responses on `backend`, as the Frontend does.
struct Responses {
  porta::PyramidLayout pyramid_layout, response_layout;
  std::unique_ptr<porta::Buffer> pyramid, responses, lut, resize;
};

Responses make_responses(porta::Backend& b, const porta::FrontendTables& t, const porta::Image& image) {
  Responses r;
  r.pyramid_layout = porta::PyramidLayout::make(t.level_sizes, 1);
  r.response_layout = porta::PyramidLayout::make(t.level_sizes, 2);
  r.pyramid = b.allocate(static_cast<std::size_t>(r.pyramid_layout.total_bytes));
  r.responses = b.allocate(static_cast<std::size_t>(r.response_layout.total_bytes));
  r.lut = b.allocate(t.fast_lut.size());
  b.upload(*r.lut, 0, t.fast_lut.data(), t.fast_lut.size());
  const auto& packed = t.resize.packed.empty() ? std::vector<std::int32_t>{0} : t.resize.packed;
  r.resize = b.allocate(packed.size() * 4);
  b.upload(*r.resize, 0, packed.data(), packed.size() * 4);
  const porta::Plane& l0 = r.pyramid_layout.levels[0];
  std::vector<std::uint8_t> staging(static_cast<std::size_t>(l0.pitch) * static_cast<std::size_t>(l0.height), 0);
  for (int y = 0; y < image.height(); ++y)
    std::memcpy(staging.data() + static_cast<std::size_t>(y) * l0.pitch, image.row(y),
                static_cast<std::size_t>(image.width()));
  b.upload(*r.pyramid, 0, staging.data(), staging.size());
  b.build_pyramid(*r.pyramid, r.pyramid_layout, *r.resize, t.resize.level_offset);
  b.fast_crf(*r.pyramid, r.pyramid_layout, *r.lut, *r.responses, r.response_layout,
             porta::FastParams{t.settings.fast_threshold, t.settings.edge});
  b.synchronize();
  return r;
}

std::vector<CullRow> run_cull(const Options& o, porta::cuda::CudaBackend& cuda, porta::Backend* cpu,
                              const porta::Image* pgm) {
  using porta::cuda::CullVariant;
  std::vector<CullVariant> variants{CullVariant::kMlptTewa, CullVariant::kMlptBlock, CullVariant::kLog2Block};
  if (!o.variant.empty()) variants = {porta::cuda::parse_cull_variant(o.variant)};
  std::vector<CullRow> rows;
  cudaStream_t stream = nullptr;
  check(cudaStreamCreateWithFlags(&stream, cudaStreamNonBlocking), "cudaStreamCreateWithFlags");
  const int reps = o.reps;
  std::vector<cudaEvent_t> starts(static_cast<std::size_t>(reps)), stops(static_cast<std::size_t>(reps));
  for (int i = 0; i < reps; ++i) {
    check(cudaEventCreate(&starts[static_cast<std::size_t>(i)]), "cudaEventCreate");
    check(cudaEventCreate(&stops[static_cast<std::size_t>(i)]), "cudaEventCreate");
  }
  const std::pair<int, int> sizes[] = {{1242, 375}, {640, 480}};
  for (const auto& [w, h] : sizes) {
    const porta::Image image = make_inputs(w, h, 1, pgm)[0].left;
    for (int cell : {32, 16}) {
      porta::FrontendSettings s;
      s.levels = 8;
      s.cell_width = s.cell_height = cell;
      const porta::FrontendTables t = porta::FrontendTables::build(s, w, h);
      const Responses r = make_responses(cuda, t, image);
      const std::size_t cell_bytes = static_cast<std::size_t>(t.cells.total_cells) * sizeof(porta::Keypoint);
      std::vector<std::uint8_t> cpu_cells;
      if (cpu) {
        const Responses rc = make_responses(*cpu, t, image);
        auto cells = cpu->allocate(cell_bytes);
        cpu->cull_cells(*rc.responses, rc.response_layout, t.cells, *cells);
        cpu_cells.resize(cell_bytes);
        cpu->download(*cells, 0, cpu_cells.data(), cell_bytes);
      }
      std::vector<std::uint8_t> first;
      for (CullVariant v : variants) {
        auto cells = cuda.allocate(cell_bytes);
        cuda.synchronize();
        const porta::cuda::CullLaunch plan = porta::cuda::plan_cull(r.response_layout, t.cells, cuda.mlpt_nmax(), v);
        const auto* resp = porta::cuda::dev<std::uint8_t>(*r.responses);
        auto* out = porta::cuda::dev<porta::cuda::DevKeypoint>(*cells);
        auto launch = [&] { check(porta::cuda::launch_cull_cells(resp, plan, out, stream), "cull_cells launch"); };
        if (o.profile_once) {
          launch();
          check(cudaStreamSynchronize(stream), "cudaStreamSynchronize");
          std::cout << "profile launch " << rows.size() << ": " << w << "x" << h << " levels " << s.levels << " cell "
                    << cell << " " << porta::cuda::cull_variant_name(v) << " (grid " << plan.first_block[plan.count]
                    << ", block " << plan.block_threads << ")\n";
          rows.push_back(CullRow{w, h, s.levels, cell, porta::cuda::cull_variant_name(v), plan.first_block[plan.count],
                                 plan.block_threads, t.cells.total_cells, Summary{}, 0.0, true, true});
          continue;
        }
        for (int i = 0; i < std::max(o.warmup, 3); ++i) launch();
        check(cudaStreamSynchronize(stream), "cudaStreamSynchronize");
        std::vector<double> us;
        for (int i = 0; i < reps; ++i) {
          check(cudaEventRecord(starts[static_cast<std::size_t>(i)], stream), "cudaEventRecord");
          launch();
          check(cudaEventRecord(stops[static_cast<std::size_t>(i)], stream), "cudaEventRecord");
        }
        check(cudaStreamSynchronize(stream), "cudaStreamSynchronize");
        for (int i = 0; i < reps; ++i) {
          float ms = 0;
          check(cudaEventElapsedTime(&ms, starts[static_cast<std::size_t>(i)], stops[static_cast<std::size_t>(i)]),
                "cudaEventElapsedTime");
          us.push_back(1000.0 * ms);
        }
        check(cudaEventRecord(starts[0], stream), "cudaEventRecord");
        for (int i = 0; i < reps; ++i) launch();
        check(cudaEventRecord(stops[0], stream), "cudaEventRecord");
        check(cudaStreamSynchronize(stream), "cudaStreamSynchronize");
        float total_ms = 0;
        check(cudaEventElapsedTime(&total_ms, starts[0], stops[0]), "cudaEventElapsedTime");
        std::vector<std::uint8_t> got(cell_bytes);
        check(cudaMemcpy(got.data(), out, cell_bytes, cudaMemcpyDeviceToHost), "cudaMemcpy");
        if (first.empty()) first = got;
        CullRow row{w, h, s.levels, cell, porta::cuda::cull_variant_name(v), plan.first_block[plan.count],
                    plan.block_threads, t.cells.total_cells, summarize(us),
                    1000.0 * total_ms / reps, cpu ? got == cpu_cells : true, got == first};
        rows.push_back(row);
        cells.reset();
      }
    }
  }
  for (int i = 0; i < reps; ++i) {
    static_cast<void>(cudaEventDestroy(starts[static_cast<std::size_t>(i)]));
    static_cast<void>(cudaEventDestroy(stops[static_cast<std::size_t>(i)]));
  }
  static_cast<void>(cudaStreamDestroy(stream));
  return rows;
}

// ---- Frame timing ----------------------------------------------------------------------------------

/// Mean per stage with FrontendOptions::profile_stages (a synchronize after every stage, so the
/// two queues do not overlap): where a frame's time goes, not the frame time.
struct StageRow {
  std::string workload;
  int frames;
  porta::StageTimes mean;  // ns
};

struct FrameRow {
  std::string workload;  // "stereo 1242x375 L8" or "mono 320x240 L1 detect"
  bool graphs, streams;
  int frames;
  Summary us;
  double fps;  // frames over the whole timed run
  double keypoints, matches;  // per frame, mean
  porta::cuda::CudaStats stats;
  bool same_as_reference;  // same bytes as the first configuration (and the cpu, where checked)
};

std::uint64_t mix(std::uint64_t h, const void* data, std::size_t n) {
  const auto* p = static_cast<const std::uint8_t*>(data);
  for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 1099511628211ull;
  return h;
}
std::uint64_t digest(const porta::Features& f, std::uint64_t h) {
  h = mix(h, f.keypoints.data(), f.keypoints.size() * sizeof(porta::Keypoint));
  return mix(h, f.descriptors.data(), f.descriptors.size() * sizeof(porta::Descriptor));
}
std::uint64_t digest(const porta::StereoFeatures& s) {
  std::uint64_t h = digest(s.right, digest(s.left, 1469598103934665603ull));
  return mix(h, s.matches.data(), s.matches.size() * sizeof(porta::StereoMatch));
}

std::vector<FrameRow> run_frames(const Options& o, porta::cuda::CudaBackend& cuda, porta::Backend* cpu,
                                 const porta::Image* pgm, std::vector<StageRow>* stage_rows) {
  std::vector<FrameRow> rows;
  struct Workload {
    std::string name;
    int width, height, levels;
    bool stereo;
  };
  const Workload workloads[] = {{"stereo 1242x375 L8 (detect+extract+stereo)", 1242, 375, 8, true},
                                {"mono 320x240 L1 (detect only)", 320, 240, 1, false}};
  for (const Workload& wl : workloads) {
    const std::vector<Pair> inputs = make_inputs(wl.width, wl.height, o.inputs, pgm);
    porta::FrontendSettings s;
    s.levels = wl.levels;
    porta::FrontendOptions fo;
    fo.describe = wl.stereo;
    // Reference digests: the cpu backend on every input (or the first configuration).
    std::vector<std::uint64_t> reference;
    if (cpu) {
      porta::Frontend f(*cpu, s, wl.width, wl.height, fo);
      for (const Pair& p : inputs)
        reference.push_back(wl.stereo ? digest(f.detect_stereo(p.left.view(), p.right.view()))
                                      : digest(f.detect(p.left.view()), 7));
    }
    for (const bool graphs : {true, false}) {
      for (const bool streams : {true, false}) {
        cuda.set_graph_mode(graphs ? porta::cuda::GraphMode::kRepeat : porta::cuda::GraphMode::kOff);
        cuda.set_streams_enabled(streams);
        porta::Frontend f(cuda, s, wl.width, wl.height, fo);
        bool same = true;
        // Digests (checks) only outside the timed frames: hashing the outputs costs more than a frame.
        auto run_one = [&](std::size_t i, double* kps, double* matches, bool check_bytes) {
          const Pair& p = inputs[i % inputs.size()];
          std::uint64_t d = 0;
          if (wl.stereo) {
            const porta::StereoFeatures out = f.detect_stereo(p.left.view(), p.right.view());
            if (check_bytes) d = digest(out);
            if (kps) *kps += static_cast<double>(out.left.keypoints.size() + out.right.keypoints.size()) / 2;
            if (matches) *matches += out.num_matches();
          } else {
            const porta::Features out = f.detect(p.left.view());
            if (check_bytes) d = digest(out, 7);
            if (kps) *kps += static_cast<double>(out.keypoints.size());
          }
          if (!check_bytes) return;
          const std::size_t k = i % inputs.size();
          if (reference.size() <= k) reference.resize(k + 1, 0);
          if (reference[k] == 0) reference[k] = d;
          if (reference[k] != d) same = false;
        };
        // Warm-up, checked: the first frames run directly, later ones as graph replays.
        const int warmup = std::max(o.warmup, 3 * static_cast<int>(inputs.size()));
        for (int i = 0; i < warmup; ++i) run_one(static_cast<std::size_t>(i), nullptr, nullptr, true);
        cuda.reset_stats();
        std::vector<double> us;
        us.reserve(static_cast<std::size_t>(o.frames));
        double kps = 0, matches = 0;
        const auto t0 = std::chrono::steady_clock::now();
        for (int i = 0; i < o.frames; ++i) {
          const auto a = std::chrono::steady_clock::now();
          run_one(static_cast<std::size_t>(i), &kps, &matches, false);
          const auto b = std::chrono::steady_clock::now();
          us.push_back(std::chrono::duration<double, std::micro>(b - a).count());
        }
        const double total_s =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        const porta::cuda::CudaStats timed_stats = cuda.stats();
        for (std::size_t i = 0; i < inputs.size(); ++i) run_one(i, nullptr, nullptr, true);  // checked again
        FrameRow row{wl.name, graphs, streams, o.frames, summarize(us), o.frames / total_s,
                     kps / o.frames, matches / o.frames, timed_stats, same};
        rows.push_back(row);
      }
    }
    // Stage attribution (graphs and streams on).
    cuda.set_graph_mode(porta::cuda::GraphMode::kRepeat);
    cuda.set_streams_enabled(true);
    porta::FrontendOptions po = fo;
    po.profile_stages = true;
    porta::Frontend pf(cuda, s, wl.width, wl.height, po);
    StageRow sr{wl.name, std::max(o.frames / 4, 50), {}};
    std::vector<porta::StageTimes> all;
    for (int i = 0; i < o.warmup + sr.frames; ++i) {
      const Pair& p = inputs[static_cast<std::size_t>(i) % inputs.size()];
      if (wl.stereo)
        static_cast<void>(pf.detect_stereo(p.left.view(), p.right.view()));
      else
        static_cast<void>(pf.detect(p.left.view()));
      if (i >= o.warmup) all.push_back(pf.last_times());
    }
    porta::StageTimes& m = sr.mean;
    for (const porta::StageTimes& t : all) {
      m.upload_ns += t.upload_ns;
      m.pyramid_ns += t.pyramid_ns;
      m.fast_ns += t.fast_ns;
      m.cull_ns += t.cull_ns;
      m.pfa_ns += t.pfa_ns;
      m.orient_ns += t.orient_ns;
      m.blur_ns += t.blur_ns;
      m.describe_ns += t.describe_ns;
      m.stereo_ns += t.stereo_ns;
      m.download_ns += t.download_ns;
      m.total_ns += t.total_ns;
    }
    const auto n = static_cast<std::int64_t>(all.size());
    for (std::int64_t* f : {&m.upload_ns, &m.pyramid_ns, &m.fast_ns, &m.cull_ns, &m.pfa_ns, &m.orient_ns, &m.blur_ns,
                            &m.describe_ns, &m.stereo_ns, &m.download_ns, &m.total_ns})
      *f /= n;
    stage_rows->push_back(sr);
  }
  cuda.set_graph_mode(porta::cuda::GraphMode::kRepeat);
  cuda.set_streams_enabled(true);
  return rows;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const Options o = parse(argc, argv);
    std::unique_ptr<porta::Image> pgm;
    if (!o.pgm.empty()) pgm = std::make_unique<porta::Image>(read_pgm(o.pgm));
    porta::cuda::CudaBackend cuda;
    std::unique_ptr<porta::Backend> cpu;
    if (o.cpu_check) cpu = porta::BackendRegistry::instance().create("cpu");
    std::cout << "device: " << cuda.device_name() << "\n";
    std::cout << "input: " << (pgm ? o.pgm : std::string("synthetic texture")) << "; MLPT N_max "
              << cuda.mlpt_nmax() << "\n";
    std::ostringstream json;
    json << "{\"device\": \"" << cuda.device_name() << "\", \"mlpt_nmax\": " << cuda.mlpt_nmax();
    bool all_same = true;

    if (o.mode == "cull" || o.mode == "all") {
      const auto rows = run_cull(o, cuda, cpu.get(), pgm.get());
      std::cout << "\nculling kernel alone (us per launch; events around each of " << o.reps
                << " launches; b2b = mean of " << o.reps << " back-to-back launches)\n";
      std::cout << "| size | levels | cell | variant | blocks | threads/block | median | p10 | p90 | b2b | = cpu |\n"
                   "|---|---|---|---|---|---|---|---|---|---|---|\n";
      json << ", \"cull\": [";
      for (std::size_t i = 0; i < rows.size(); ++i) {
        const CullRow& r = rows[i];
        const bool same = r.same_as_cpu && r.same_as_first_variant;
        all_same = all_same && same;
        std::cout << "| " << r.width << "x" << r.height << " | " << r.levels << " | " << r.cell << " | " << r.variant
                  << " | " << r.blocks << " | " << r.threads_per_block << " | " << fmt(r.us.median) << " | "
                  << fmt(r.us.p10) << " | " << fmt(r.us.p90) << " | " << fmt(r.back_to_back_us) << " | "
                  << (same ? "yes" : "NO") << " |\n";
        json << (i ? ", " : "") << "{\"width\": " << r.width << ", \"height\": " << r.height
             << ", \"levels\": " << r.levels << ", \"cell\": " << r.cell << ", \"variant\": \"" << r.variant
             << "\", \"blocks\": " << r.blocks << ", \"threads_per_block\": " << r.threads_per_block
             << ", \"cells\": " << r.total_cells << ", \"reps\": " << o.reps << ", \"median_us\": " << fmt(r.us.median, 3)
             << ", \"p10_us\": " << fmt(r.us.p10, 3) << ", \"p90_us\": " << fmt(r.us.p90, 3)
             << ", \"back_to_back_us\": " << fmt(r.back_to_back_us, 3)
             << ", \"same_as_cpu\": " << (r.same_as_cpu ? "true" : "false")
             << ", \"same_as_mlpt_tewa\": " << (r.same_as_first_variant ? "true" : "false") << "}";
      }
      json << "]";
    }

    if (o.mode == "frames" || o.mode == "all") {
      std::vector<StageRow> stages;
      const auto rows = run_frames(o, cuda, cpu.get(), pgm.get(), &stages);
      std::cout << "\nwhole frames through porta::Frontend on cuda (" << o.frames << " timed frames after "
                << o.warmup << ", " << o.inputs << " inputs in turn; wall clock per frame in us)\n";
      std::cout << "| workload | graphs | streams | median | p10 | p90 | frames/s | kp/img | matches | "
                   "graph replays | direct segments | same bytes |\n"
                   "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
      json << ", \"frames\": [";
      for (std::size_t i = 0; i < rows.size(); ++i) {
        const FrameRow& r = rows[i];
        all_same = all_same && r.same_as_reference;
        std::cout << "| " << r.workload << " | " << (r.graphs ? "on" : "off") << " | " << (r.streams ? "on" : "off")
                  << " | " << fmt(r.us.median, 1) << " | " << fmt(r.us.p10, 1) << " | " << fmt(r.us.p90, 1) << " | "
                  << fmt(r.fps, 0) << " | " << fmt(r.keypoints, 0) << " | " << fmt(r.matches, 0) << " | "
                  << r.stats.graph_replays << " | " << r.stats.direct_segments << " | "
                  << (r.same_as_reference ? "yes" : "NO") << " |\n";
        json << (i ? ", " : "") << "{\"workload\": \"" << r.workload << "\", \"graphs\": " << (r.graphs ? "true" : "false")
             << ", \"streams\": " << (r.streams ? "true" : "false") << ", \"frames\": " << r.frames
             << ", \"median_us\": " << fmt(r.us.median, 2) << ", \"p10_us\": " << fmt(r.us.p10, 2)
             << ", \"p90_us\": " << fmt(r.us.p90, 2) << ", \"mean_us\": " << fmt(r.us.mean, 2)
             << ", \"frames_per_s\": " << fmt(r.fps, 1) << ", \"keypoints_per_image\": " << fmt(r.keypoints, 1)
             << ", \"matches\": " << fmt(r.matches, 1) << ", \"graph_replays\": " << r.stats.graph_replays
             << ", \"graph_captures\": " << r.stats.graph_captures << ", \"direct_segments\": " << r.stats.direct_segments
             << ", \"operations\": " << r.stats.operations
             << ", \"same_bytes\": " << (r.same_as_reference ? "true" : "false") << "}";
      }
      json << "]";
      std::cout << "\nstage attribution (FrontendOptions::profile_stages: synchronize after each stage, queues "
                   "serialised; mean us per frame, both images; upload = host copies + transfer, pfa = PFA + "
                   "compaction, download = counts, keypoints, descriptors; stereo includes its download)\n";
      std::cout << "| workload | frames | upload | pyramid | fast | cull | pfa | orient | blur | describe | download | "
                   "stereo | total |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
      json << ", \"stages_us\": [";
      for (std::size_t i = 0; i < stages.size(); ++i) {
        const StageRow& r = stages[i];
        const porta::StageTimes& m = r.mean;
        const std::int64_t v[] = {m.upload_ns, m.pyramid_ns, m.fast_ns, m.cull_ns, m.pfa_ns, m.orient_ns,
                                  m.blur_ns, m.describe_ns, m.download_ns, m.stereo_ns, m.total_ns};
        const char* names[] = {"upload", "pyramid", "fast", "cull", "pfa", "orient", "blur", "describe",
                               "download", "stereo", "total"};
        std::cout << "| " << r.workload << " | " << r.frames;
        json << (i ? ", " : "") << "{\"workload\": \"" << r.workload << "\"";
        for (std::size_t k = 0; k < 11; ++k) {
          std::cout << " | " << fmt(static_cast<double>(v[k]) / 1000.0, 1);
          json << ", \"" << names[k] << "\": " << fmt(static_cast<double>(v[k]) / 1000.0, 2);
        }
        std::cout << " |\n";
        json << "}";
      }
      json << "]";
    }
    json << ", \"all_bit_identical\": " << (all_same ? "true" : "false") << "}";
    std::cout << "\nJSON: " << json.str() << "\n";
    if (!o.json.empty()) {
      std::ofstream out(o.json);
      out << json.str() << "\n";
    }
    if (!all_same) {
      std::cout << "porta_cuda_ablation: RESULTS DIFFER between variants/configurations or from cpu\n";
      return 1;
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "porta_cuda_ablation: " << e.what() << "\n";
    return 1;
  }
}
