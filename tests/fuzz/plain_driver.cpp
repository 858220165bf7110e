// The fuzz targets without libFuzzer (GCC builds, and CI's quick check): runs a target on every
// seed file, then on deterministic mutations of each (bit flips, byte changes, truncations,
// duplicated and deleted spans, inserted interesting bytes). A crash, a sanitizer report or an
// undocumented exception ends the process with the input saved as crash-<program name> in the working folder.
//   usage: porta_fuzz_<target> [--mutations N] [--seed S] SEED_FILE_OR_FOLDER...
#include <algorithm>
#include <charconv>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;

Bytes read_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return Bytes(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

Bytes mutate(const Bytes& seed, std::mt19937_64& rng) {
  Bytes b = seed;
  const auto pick = [&](std::size_t n) { return n == 0 ? std::size_t{0} : static_cast<std::size_t>(rng() % n); };
  static const std::uint8_t kInteresting[] = {0, 1, 0x7f, 0x80, 0xff, '-', '.', 'e', '9', '\n', ',', ':', ' '};
  const int edits = 1 + static_cast<int>(rng() % 4);
  for (int e = 0; e < edits; ++e) {
    switch (rng() % 6) {
      case 0:
        if (!b.empty()) b[pick(b.size())] ^= static_cast<std::uint8_t>(1u << (rng() % 8));
        break;
      case 1:
        if (!b.empty()) b[pick(b.size())] = static_cast<std::uint8_t>(rng());
        break;
      case 2:
        b.resize(pick(b.size() + 1));
        break;
      case 3: {  // duplicate a span
        if (b.empty()) break;
        const std::size_t from = pick(b.size()), len = 1 + pick(std::min<std::size_t>(64, b.size() - from));
        const Bytes span(b.begin() + static_cast<std::ptrdiff_t>(from), b.begin() + static_cast<std::ptrdiff_t>(from + len));
        b.insert(b.begin() + static_cast<std::ptrdiff_t>(pick(b.size() + 1)), span.begin(), span.end());
        break;
      }
      case 4: {  // delete a span
        if (b.empty()) break;
        const std::size_t from = pick(b.size()), len = 1 + pick(std::min<std::size_t>(64, b.size() - from));
        b.erase(b.begin() + static_cast<std::ptrdiff_t>(from), b.begin() + static_cast<std::ptrdiff_t>(from + len));
        break;
      }
      default:
        b.insert(b.begin() + static_cast<std::ptrdiff_t>(pick(b.size() + 1)),
                 kInteresting[pick(sizeof kInteresting)]);
        break;
    }
  }
  return b;
}

long long parse_count(const char* text, const char* option) {
  long long v = 0;
  const std::string s(text);
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size() || v < 0) {
    std::fprintf(stderr, "fuzz driver: %s expects a count >= 0, got '%s'\n", option, text);
    std::exit(2);
  }
  return v;
}

}  // namespace

int main(int argc, char** argv) {
  long long mutations = 200, seed = 1;
  std::vector<fs::path> seeds;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if ((a == "--mutations" || a == "--seed") && i + 1 < argc) {
      (a == "--mutations" ? mutations : seed) = parse_count(argv[++i], a.c_str());
    } else if (fs::is_directory(a)) {
      for (const auto& e : fs::directory_iterator(a))
        if (e.is_regular_file()) seeds.push_back(e.path());
    } else if (fs::is_regular_file(a)) {
      seeds.emplace_back(a);
    } else {
      std::fprintf(stderr, "fuzz driver: '%s' is neither a seed file nor a folder of seeds\n", a.c_str());
      return 2;
    }
  }
  if (seeds.empty()) {
    std::fprintf(stderr, "fuzz driver: no seeds given (usage: %s [--mutations N] [--seed S] SEEDS...)\n", argv[0]);
    return 2;
  }
  std::sort(seeds.begin(), seeds.end());
  std::mt19937_64 rng(static_cast<std::uint64_t>(seed));
  long long executions = 0;
  static const std::string crash_file = "crash-" + fs::path(argv[0]).filename().string();
  std::set_terminate([] {
    std::fprintf(stderr, "fuzz driver: an undocumented exception escaped the target; the input is in crash-<program>\n");
    std::abort();
  });
  const auto run = [&](const Bytes& input) {
    {
      std::ofstream(crash_file, std::ios::binary | std::ios::trunc)
          .write(reinterpret_cast<const char*>(input.data()), static_cast<std::streamsize>(input.size()));
    }
    LLVMFuzzerTestOneInput(input.data(), input.size());
    ++executions;
  };
  for (const fs::path& path : seeds) {
    const Bytes original = read_file(path);
    run(original);
    for (long long m = 0; m < mutations; ++m) run(mutate(original, rng));
  }
  std::error_code ignored;
  fs::remove(crash_file, ignored);
  std::printf("fuzz driver: %lld executions over %zu seeds, no crash, no undocumented exception\n", executions,
              seeds.size());
  return 0;
}
