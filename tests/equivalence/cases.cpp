// The covering design of the suite: which (inputs, settings, variant) each kernel is run with.
// Not the full cartesian product (CI runs it on 2 cores through PoCL): every kernel sees every
// input class and size of the catalogue, and every settings profile (which between them take every
// swept value: levels 1/4/8/12, cells 8-64 and rectangular, PFA on/off, FAST threshold 7/20/40,
// max arc 13/16, orientation bins 32/12), with the pairing rotated per kernel so that different
// kernels meet different (image, settings) combinations. Then the whole Frontend, mono and stereo,
// two frames in a row through the same Frontend.
#include <cctype>
#include <set>
#include <stdexcept>
#include <tuple>

#include "equivalence/harness.hpp"
#include "equivalence/inputs.hpp"

namespace porta::eq {

namespace {

/// Images every single-image kernel sees, one case each: every class, tiny and odd sizes, sizes
/// around cell multiples, padded pitches, and the real photographs.
const std::vector<std::string> kImages = {
    "rnd_1x1",
    "rnd_2x3",
    "rnd_7x5",
    "rnd_31x33",
    "rnd_64x64",
    "rnd_95x97_pitch108",
    "rnd_97x95",
    "rnd_129x127",
    "rnd_333x257_pitch346",
    "rnd_640x480",
    "rnd_1242x375_pitch1255",
    "flat0_64x48",
    "flat128_333x257",
    "flat255_640x480_pitch653",
    "checker1_128x96",
    "checker3_333x257",
    "checker8_640x480_pitch704",
    "tex_96x96",
    "tex_333x257_pitch401",
    "tex_640x480",
    "tex_1242x375",
    "tsukuba_im2",
    "bikes_img1",
    "kitti07_000000",
    "euroc_cam0_0",
};

/// Combinations every single-image kernel sees in addition: the largest images with the most
/// levels and smallest cells, a 1x1 image with 12 levels, and the defaults on a texture.
const std::vector<std::pair<std::string, int>> kExtras = {
    {"kitti07_000000", 3}, {"rnd_1242x375_pitch1255", 6}, {"tex_640x480", 0},
    {"rnd_1x1", 3},        {"tex_1242x375", 6},
};

/// Stereo pairs (left, right) with the profiles each is run with; every profile appears.
const std::vector<std::tuple<std::string, std::string, std::vector<int>>> kPairs = {
    {"tsukuba_im2", "tsukuba_im6", {0, 3, 6}},
    {"tsukuba_im6", "tsukuba_im2", {2}},  // swapped: disparities negative, nearly all rejected
    {"tex_640x480", "tex_640x480_shift12", {0, 2, 4}},
    {"tex_640x480_b", "tex_640x480_b_shift7", {6, 7}},
    {"tex_1242x375", "tex_1242x375_shift30", {6, 3}},
    {"euroc_cam0_0", "euroc_cam1_0", {2, 5}},
    {"tex_333x257_pitch401", "tex_333x257_shift6", {1, 7, 5}},
    {"rnd_333x257_pitch346", "rnd_333x257_shift5", {1, 4}},
    {"checker3_333x257", "checker3_333x257_shift4", {0, 3}},
    {"flat0_64x48", "flat0_64x48", {0}},
    {"rnd_1x1", "rnd_1x1_b", {3}},
    {"rnd_2x3", "rnd_2x3_b", {1}},
};

/// Scenes whose keypoints and descriptors projection matching searches; the checkerboard has many
/// identical descriptors (ties), the flat image none at all (every window empty).
const std::vector<std::pair<std::string, int>> kProjectionScenes = {
    {"tsukuba_im2", 0},      {"kitti07_000000", 3}, {"tex_640x480", 6},
    {"checker3_333x257", 0}, {"flat0_64x48", 0},    {"rnd_1242x375_pitch1255", 4},
    {"bikes_img1", 2},       {"euroc_cam0_0", 5},   {"tex_333x257_pitch401", 7},
};

struct FrontendSpec {
  bool stereo;
  std::vector<std::string> frames;  ///< mono: one image per frame; stereo: left, right per frame
  int profile;
};
/// Two frames through the same Frontend each: rich then empty and empty then rich (stale buffers).
const std::vector<FrontendSpec> kFrontend = {
    {true, {"tsukuba_im2", "tsukuba_im6", "tsukuba_im6", "tsukuba_im2"}, 0},
    {true, {"tex_640x480", "tex_640x480_shift12", "tex_640x480_b", "tex_640x480_b_shift7"}, 0},
    {true, {"euroc_cam0_0", "euroc_cam1_0", "euroc_cam0_1", "euroc_cam1_1"}, 2},
    {false, {"kitti07_000000", "kitti07_000001"}, 3},
    {false, {"bikes_img1", "bikes_img2"}, 4},
    {false, {"rnd_1242x375_pitch1255", "tex_1242x375"}, 1},
    {true, {"rnd_1x1", "rnd_1x1_b", "rnd_1x1_b", "rnd_1x1"}, 6},
    {true, {"rnd_2x3", "rnd_2x3_b", "rnd_2x3_b", "rnd_2x3"}, 1},
    {false, {"rnd_95x97_pitch108", "rnd_95x97_pitch108"}, 5},
    {false, {"flat255_640x480_pitch653", "tex_640x480"}, 0},
    {false, {"tex_640x480", "flat255_640x480_pitch653"}, 6},
    {true, {"checker3_333x257", "checker3_333x257_shift4", "tex_333x257_pitch401", "tex_333x257_shift6"}, 3},
    {true, {"tex_333x257_pitch401", "tex_333x257_shift6", "rnd_333x257_pitch346", "rnd_333x257_shift5"}, 7},
    {false, {"checker1_128x96", "checker1_128x96"}, 2},
    {false, {"rnd_64x64", "rnd_64x64"}, 4},
    {true, {"flat0_64x48", "flat0_64x48", "flat0_64x48", "flat0_64x48"}, 6},
    {true, {"tex_1242x375", "tex_1242x375_shift30", "tex_1242x375", "tex_1242x375_shift30"}, 6},
    {true, {"rnd_333x257_pitch346", "rnd_333x257_shift5", "flat128_333x257", "flat128_333x257"}, 4},
};

const char* const kRectifyMaps[] = {"map_barrel", "map_pincushion_resized", "map_rotated_off_image"};

int kernel_index(const std::string& kernel) {
  const auto& k = summary_kernels();
  for (std::size_t i = 0; i < k.size(); ++i)
    if (k[i] == kernel) return static_cast<int>(i);
  throw std::logic_error("equivalence: unknown kernel " + kernel);
}

bool takes_list(const std::string& kernel) {
  return kernel == "compact_keypoints" || kernel == "orient" || kernel == "orb_describe";
}

/// The backend-free cases of one kernel.
std::vector<KernelCase> specs_for(const std::string& kernel) {
  std::vector<KernelCase> out;
  const int k = kernel_index(kernel);
  const int num_profiles = static_cast<int>(profiles().size());
  auto add = [&](std::vector<std::string> inputs, int profile, int variant, std::string label,
                 bool stereo = false) {
    out.push_back({kernel, {}, std::move(inputs), profile, variant, std::move(label), stereo});
  };
  if (kernel == "rectify") {
    for (std::size_t i = 0; i < kImages.size(); ++i) {
      const int v = static_cast<int>(i) % 3;
      add({kImages[i]}, 0, v, kRectifyMaps[v]);
    }
  } else if (kernel == "stereo_match") {
    int v = 0;
    for (const auto& [left, right, ps] : kPairs)
      for (int p : ps) {
        add({left, right}, p, v, v % 2 ? "count8" : "");
        ++v;
      }
  } else if (kernel == "projection_match") {
    int v = 0;
    for (const auto& [image, p] : kProjectionScenes) {
      add({image}, p, v, "queries" + std::to_string(v));
      ++v;
    }
  } else if (kernel == "frontend") {
    for (const FrontendSpec& f : kFrontend) add(f.frames, f.profile, 0, {}, f.stereo);
  } else {
    std::set<std::pair<std::string, int>> seen;
    for (std::size_t i = 0; i < kImages.size(); ++i) {
      const int p = (static_cast<int>(i) + 3 * k) % num_profiles;
      const int v = static_cast<int>(i);
      add({kImages[i]}, p, v, takes_list(kernel) && v % 2 ? "count8" : "");
      seen.insert({kImages[i], p});
    }
    int v = static_cast<int>(kImages.size());
    for (const auto& [image, p] : kExtras) {
      if (!seen.insert({image, p}).second) continue;
      add({image}, p, v, takes_list(kernel) && v % 2 ? "count8" : "");
      ++v;
    }
  }
  return out;
}

std::string identifier(const std::string& s) {
  std::string out;
  for (char c : s) out += (std::isalnum(static_cast<unsigned char>(c)) != 0) ? c : '_';
  return out;
}

}  // namespace

std::vector<KernelCase> cases_for(const std::string& kernel) {
  std::vector<KernelCase> out;
  // Backends inner, so that consecutive cases share the cpu-made scenes (inputs.cpp caches a few).
  for (const KernelCase& spec : specs_for(kernel))
    for (const auto& backend : backends_under_test()) {
      KernelCase c = spec;
      c.backend = backend;
      out.push_back(std::move(c));
    }
  return out;
}

std::string case_name(const ::testing::TestParamInfo<KernelCase>& info) {
  const KernelCase& c = info.param;
  std::string name = c.backend + "_";
  if (c.kernel == "frontend") name += c.stereo ? "stereo_" : "mono_";
  for (const auto& in : c.inputs) name += in + "_";
  name += c.kernel == "rectify" ? std::string{} : profiles().at(static_cast<std::size_t>(c.profile)).label;
  if (!c.variant_label.empty()) name += (name.back() == '_' ? "" : "_") + c.variant_label;
  if (name.back() == '_') name.pop_back();
  return identifier(name);
}

void PrintTo(const KernelCase& c, std::ostream* os) {
  *os << "{" << c.kernel << " on " << c.backend << ", inputs";
  for (const auto& in : c.inputs) *os << " " << in;
  if (c.kernel != "rectify") *os << ", settings " << profiles().at(static_cast<std::size_t>(c.profile)).label;
  if (!c.variant_label.empty()) *os << ", " << c.variant_label;
  *os << "}";
}

}  // namespace porta::eq
