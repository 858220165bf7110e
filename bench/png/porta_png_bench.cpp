// porta_png_bench: reading a dataset's PNG images, imageio's reader (read_png_gray: 8-bit gray
// through libdeflate, png_gray8.hpp) against libpng alone on the same files (docs/BENCHMARKS.md,
// "Reading the images"). Google Benchmark; one iteration reads one file, cycling through the
// first 100 PNG files of the folder PORTA_PNG_BENCH_DIR (e.g. a KITTI sequence's image_0), else
// of a 1242x375 textured image with noise written here.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "imageio/png_file.hpp"
#include "imageio/png_gray8.hpp"

namespace {

namespace fs = std::filesystem;

const std::vector<std::string>& files() {
  static const std::vector<std::string> list = [] {
    std::vector<std::string> out;
    if (const char* dir = std::getenv("PORTA_PNG_BENCH_DIR")) {
      std::error_code ec;
      for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
        if (it->path().extension() == ".png") out.push_back(it->path().string());
      if (ec || out.empty()) {
        std::fprintf(stderr, "porta_png_bench: PORTA_PNG_BENCH_DIR '%s': %s\n", dir,
                     ec ? ec.message().c_str() : "no .png files there");
        std::exit(2);
      }
      std::sort(out.begin(), out.end());
      if (out.size() > 100) out.resize(100);
    }
    if (out.empty()) {  // a street-like image: a gradient texture and Gaussian noise of 1 grey level
      const int w = 1242, h = 375;
      std::vector<std::uint8_t> gray(static_cast<std::size_t>(w) * h);
      std::mt19937 rng(1);
      std::normal_distribution<double> noise(0.0, 1.0);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          gray[static_cast<std::size_t>(y) * w + x] = static_cast<std::uint8_t>(
              std::clamp(100.0 + 60.0 * ((x / 7 + y / 5) % 3) / 2.0 + 20.0 * ((x * y) % 11) / 10.0 + noise(rng), 0.0,
                         255.0));
      const std::string path = (fs::temp_directory_path() / "porta_png_bench.png").string();
      porta::io::write_png_gray(path, w, h, gray.data(), static_cast<std::size_t>(w));
      out.push_back(path);
    }
    return out;
  }();
  return list;
}

template <typename Read>
void read_all(benchmark::State& state, Read read) {
  const std::vector<std::string>& list = files();
  std::size_t i = 0, bytes = 0;
  for (auto _ : state) {
    const porta::io::GrayPng png = read(list[i++ % list.size()]);
    bytes += static_cast<std::size_t>(png.gray.width()) * png.gray.height();
    benchmark::DoNotOptimize(png.gray.data());
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(bytes));
  state.counters["files"] = static_cast<double>(list.size());
}

void BM_ReadPng_Ours(benchmark::State& state) {
  if (!porta::io::detail::have_gray8_decoder()) state.SkipWithError("built without libdeflate: both are libpng");
  read_all(state, [](const std::string& f) { return porta::io::read_png_gray(f, 16384); });
}

void BM_ReadPng_Libpng(benchmark::State& state) {
  read_all(state, [](const std::string& f) { return porta::io::detail::read_png_gray_with_libpng(f, 16384); });
}

}  // namespace

BENCHMARK(BM_ReadPng_Ours)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadPng_Libpng)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
