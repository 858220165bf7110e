#include "equivalence/inputs.hpp"

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <iostream>
#include <map>
#include <sstream>
#include <stdexcept>

#include "equivalence/harness.hpp"
#include "support/data_path.hpp"
#include "support/test_images.hpp"

namespace porta::eq {

namespace {

// ---- The image catalogue -------------------------------------------------------------------------

struct Entry {
  std::string description;
  std::function<Image()> make;  ///< synthetic images
  std::string data_path;        ///< real images: path inside the shared data folder
  int data_index = -1;          ///< real images of a folder: the index of the file, sorted by name
};

using Catalogue = std::map<std::string, Entry>;

std::string size_text(int w, int h, int pitch) {
  std::string s = std::to_string(w) + "x" + std::to_string(h);
  if (pitch > w) s += " (pitch " + std::to_string(pitch) + ")";
  return s;
}

void add_random(Catalogue& c, const std::string& name, int w, int h, std::uint64_t seed, int pitch = 0) {
  c[name] = {"uniform random " + size_text(w, h, pitch) + ", seed " + std::to_string(seed),
             [=] { return test::random_image(w, h, seed, pitch); },
             {},
             -1};
}
void add_flat(Catalogue& c, const std::string& name, int w, int h, std::uint8_t value, int pitch = 0) {
  c[name] = {"flat " + std::to_string(value) + " " + size_text(w, h, pitch),
             [=] { return test::flat_image(w, h, value, pitch); },
             {},
             -1};
}
void add_checker(Catalogue& c, const std::string& name, int w, int h, int square, int pitch = 0) {
  c[name] = {"checkerboard of " + std::to_string(square) + " px squares " + size_text(w, h, pitch),
             [=] { return test::checkerboard(w, h, square, pitch); },
             {},
             -1};
}
void add_textured(Catalogue& c, const std::string& name, int w, int h, std::uint64_t seed, int pitch = 0) {
  c[name] = {"smooth random texture " + size_text(w, h, pitch) + ", seed " + std::to_string(seed),
             [=] { return test::textured_image(w, h, seed, pitch); },
             {},
             -1};
}
/// `base` seen from a camera `dx` px to its right: the scene moves left by dx (stereo disparity dx).
void add_shifted(Catalogue& c, const std::string& name, const std::string& base, int dx) {
  const Entry& b = c.at(base);
  auto make = b.make;
  c[name] = {b.description + ", shifted left by " + std::to_string(dx) + " px (right view, disparity " +
                 std::to_string(dx) + ")",
             [=] { return test::shifted_right(make(), -dx); },
             {},
             -1};
}
void add_real(Catalogue& c, const std::string& name, const std::string& path, const std::string& what,
              int index = -1) {
  c[name] = {what + " (" + path + (index >= 0 ? " file " + std::to_string(index) : std::string{}) + ")",
             {},
             path,
             index};
}

const Catalogue& catalogue() {
  static const Catalogue c = [] {
    Catalogue c;
    // Random pixels: tiny, odd, just around cell multiples (96 = 3*32 = 2*48, 128 = 4*32 = 2*64),
    // padded pitches, and the usual camera sizes.
    add_random(c, "rnd_1x1", 1, 1, 1);
    add_random(c, "rnd_1x1_b", 1, 1, 2);
    add_random(c, "rnd_2x3", 2, 3, 3);
    add_random(c, "rnd_2x3_b", 2, 3, 4);
    add_random(c, "rnd_7x5", 7, 5, 5, 13);
    add_random(c, "rnd_31x33", 31, 33, 6);
    add_random(c, "rnd_64x64", 64, 64, 7);
    add_random(c, "rnd_95x97_pitch108", 95, 97, 8, 108);
    add_random(c, "rnd_97x95", 97, 95, 9);
    add_random(c, "rnd_129x127", 129, 127, 10);
    add_random(c, "rnd_333x257_pitch346", 333, 257, 11, 346);
    add_shifted(c, "rnd_333x257_shift5", "rnd_333x257_pitch346", 5);
    add_random(c, "rnd_640x480", 640, 480, 12);
    add_random(c, "rnd_1242x375_pitch1255", 1242, 375, 13, 1255);
    // Flat (black, grey, saturated) and checkerboards: no corners, and corners everywhere.
    add_flat(c, "flat0_64x48", 64, 48, 0);
    add_flat(c, "flat128_333x257", 333, 257, 128);
    add_flat(c, "flat255_640x480_pitch653", 640, 480, 255, 653);
    add_checker(c, "checker1_128x96", 128, 96, 1);
    add_checker(c, "checker3_333x257", 333, 257, 3);
    add_shifted(c, "checker3_333x257_shift4", "checker3_333x257", 4);
    add_checker(c, "checker8_640x480_pitch704", 640, 480, 8, 704);
    // Smooth textures: natural-looking, corner-rich, good stereo.
    add_textured(c, "tex_96x96", 96, 96, 20);
    add_textured(c, "tex_333x257_pitch401", 333, 257, 21, 401);
    add_shifted(c, "tex_333x257_shift6", "tex_333x257_pitch401", 6);
    add_textured(c, "tex_640x480", 640, 480, 22);
    add_shifted(c, "tex_640x480_shift12", "tex_640x480", 12);
    add_textured(c, "tex_640x480_b", 640, 480, 23);
    add_shifted(c, "tex_640x480_b_shift7", "tex_640x480_b", 7);
    add_textured(c, "tex_1242x375", 1242, 375, 24);
    add_shifted(c, "tex_1242x375_shift30", "tex_1242x375", 30);
    // Real photographs (../shared/data).
    add_real(c, "tsukuba_im2", "middlebury/tsukuba/im2.png", "Middlebury tsukuba left");
    add_real(c, "tsukuba_im6", "middlebury/tsukuba/im6.png", "Middlebury tsukuba right");
    add_real(c, "bikes_img1", "oxford-affine/bikes/img1.png", "Oxford affine bikes 1");
    add_real(c, "bikes_img2", "oxford-affine/bikes/img2.png", "Oxford affine bikes 2");
    add_real(c, "kitti07_000000", "kitti07-left-head/image_0/000000.png", "KITTI 07 left frame 0");
    add_real(c, "kitti07_000001", "kitti07-left-head/image_0/000001.png", "KITTI 07 left frame 1");
    add_real(c, "euroc_cam0_0", "euroc-v101-head/mav0/cam0/data", "EuRoC V1_01 cam0 frame 0", 0);
    add_real(c, "euroc_cam1_0", "euroc-v101-head/mav0/cam1/data", "EuRoC V1_01 cam1 frame 0", 0);
    add_real(c, "euroc_cam0_1", "euroc-v101-head/mav0/cam0/data", "EuRoC V1_01 cam0 frame 1", 1);
    add_real(c, "euroc_cam1_1", "euroc-v101-head/mav0/cam1/data", "EuRoC V1_01 cam1 frame 1", 1);
    return c;
  }();
  return c;
}

std::unique_ptr<Image> load_real(const Entry& e, std::string& why) {
  const std::filesystem::path path = test::data_file(e.data_path);
  if (path.empty()) {
    why = test::skip_reason(e.data_path);
    return nullptr;
  }
  if (const std::string reason = test::image_loading_unavailable_reason(); !reason.empty()) {
    why = "real image " + path.string() + " not loaded: " + reason;
    return nullptr;
  }
  std::filesystem::path file = path;
  if (e.data_index >= 0) {
    std::vector<std::filesystem::path> files;
    for (const auto& f : std::filesystem::directory_iterator(path))
      if (f.path().extension() == ".png") files.push_back(f.path());
    std::sort(files.begin(), files.end());
    if (static_cast<int>(files.size()) <= e.data_index) {
      why = path.string() + " holds " + std::to_string(files.size()) + " PNG files, fewer than " +
            std::to_string(e.data_index + 1);
      return nullptr;
    }
    file = files[static_cast<std::size_t>(e.data_index)];
  }
  return std::make_unique<Image>(test::load_gray(file.string()));
}

// ---- Settings ------------------------------------------------------------------------------------

std::string scale_label(double s) {
  std::ostringstream o;
  o << s;
  std::string t = o.str();
  std::replace(t.begin(), t.end(), '.', 'p');
  return t;
}

std::string make_label(const FrontendSettings& s) {
  std::string l = "L" + std::to_string(s.levels);
  if (s.scale_factor != 1.2) l += "_s" + scale_label(s.scale_factor);
  l += "_c" + std::to_string(s.cell_width);
  if (s.cell_height != s.cell_width) l += "x" + std::to_string(s.cell_height);
  l += s.pfa ? (s.pfa_window == 3 ? "_pfa" : "_pfa" + std::to_string(s.pfa_window)) : "_nopfa";
  l += "_t" + std::to_string(s.fast_threshold);
  l += "_arc" + std::to_string(s.min_arc) + "to" + std::to_string(s.max_arc);
  l += "_b" + std::to_string(s.orientation_bins);
  if (s.edge != 19) l += "_e" + std::to_string(s.edge);
  return l;
}

struct ProfileSpec {
  int levels;
  double scale;
  int cell_w, cell_h;
  bool pfa;
  int window, threshold, min_arc, max_arc, bins, edge;
  int d_min, d_max, hamming;
};

}  // namespace

const Image* input_image(const std::string& name, std::string& why) {
  static std::map<std::string, std::unique_ptr<Image>> images;
  static std::map<std::string, std::string> failures;
  if (auto it = images.find(name); it != images.end()) return it->second.get();
  if (auto it = failures.find(name); it != failures.end()) {
    why = it->second;
    return nullptr;
  }
  const auto entry = catalogue().find(name);
  if (entry == catalogue().end()) throw std::logic_error("equivalence: no input image named " + name);
  std::unique_ptr<Image> image =
      entry->second.make ? std::make_unique<Image>(entry->second.make()) : load_real(entry->second, why);
  if (!image) {
    failures[name] = why;
    return nullptr;
  }
  return (images[name] = std::move(image)).get();
}

std::string describe_input(const std::string& name) {
  const auto entry = catalogue().find(name);
  return entry == catalogue().end() ? name : name + ": " + entry->second.description;
}

std::vector<std::string> input_names() {
  std::vector<std::string> out;
  for (const auto& [name, e] : catalogue()) out.push_back(name);
  return out;
}

const std::vector<Profile>& profiles() {
  // The covering set of settings: every swept value appears at least once (see inputs.hpp).
  static const std::vector<Profile> list = [] {
    const ProfileSpec specs[] = {
        // levels, scale, cell w, cell h, PFA, window, FAST threshold, min arc, max arc, bins, edge,
        // stereo min and max disparity, max Hamming
        {8, 1.2, 32, 32, true, 3, 20, 9, 13, 32, 19, 0, 128, 75},    // the defaults
        {1, 1.2, 8, 8, false, 3, 7, 9, 16, 12, 19, 0, 64, 50},       // one level, classic FAST
        {4, 1.2, 16, 40, true, 3, 40, 9, 13, 32, 19, 2, 96, 100},    // rectangular cells
        {12, 1.2, 48, 48, false, 3, 20, 9, 16, 12, 19, 0, 200, 75},  // every level, no PFA
        {8, 2.0, 64, 64, true, 5, 7, 9, 13, 12, 19, 0, 128, 256},    // scale 2, PFA window 5
        {4, 1.5, 16, 16, true, 3, 20, 12, 16, 32, 31, 0, 48, 75},    // scale 1.5, edge 31
        {12, 1.2, 8, 8, true, 3, 40, 9, 13, 32, 19, 0, 128, 60},     // many small cells
        {1, 1.2, 32, 32, true, 3, 20, 9, 13, 12, 19, 1, 32, 75},     // PFA over a single level
    };
    std::vector<Profile> out;
    for (const ProfileSpec& p : specs) {
      FrontendSettings s;
      s.levels = p.levels;
      s.scale_factor = p.scale;
      s.cell_width = p.cell_w;
      s.cell_height = p.cell_h;
      s.pfa = p.pfa;
      s.pfa_window = p.window;
      s.fast_threshold = p.threshold;
      s.min_arc = p.min_arc;
      s.max_arc = p.max_arc;
      s.orientation_bins = p.bins;
      s.edge = p.edge;
      s.stereo_min_disparity = p.d_min;
      s.stereo_max_disparity = p.d_max;
      s.stereo_max_hamming = p.hamming;
      s.validate();
      out.push_back({make_label(s), s});
    }
    return out;
  }();
  return list;
}

std::string describe_settings(const FrontendSettings& s) {
  std::ostringstream o;
  o << "levels " << s.levels << ", scale " << s.scale_factor << ", cells " << s.cell_width << "x"
    << s.cell_height << ", PFA "
    << (s.pfa ? "on (window " + std::to_string(s.pfa_window) + ")" : std::string("off"))
    << ", FAST threshold " << s.fast_threshold << ", arc [" << s.min_arc << ", " << s.max_arc << "], edge "
    << s.edge << ", orientation bins " << s.orientation_bins << ", stereo disparity ["
    << s.stereo_min_disparity << ", " << s.stereo_max_disparity << "] px, max Hamming "
    << s.stereo_max_hamming;
  return o.str();
}

// ---- Scenes --------------------------------------------------------------------------------------

std::string Scene::locate_cell(std::size_t index) const {
  for (std::size_t n = 0; n < tables.cells.levels.size(); ++n) {
    const LevelCells& l = tables.cells.levels[n];
    const auto first = static_cast<std::size_t>(l.first_cell);
    if (index >= first && index < first + static_cast<std::size_t>(l.count())) {
      const int local = static_cast<int>(index - first);
      return "cell " + std::to_string(index) + " (level " + std::to_string(n) + ", cell row " +
             std::to_string(local / l.cols) + ", col " + std::to_string(local % l.cols) + ")";
    }
  }
  return "cell " + std::to_string(index) + " (outside the cell layout)";
}

std::string locate_keypoint(const std::vector<Keypoint>& list, std::size_t index) {
  std::string s = "keypoint " + std::to_string(index);
  if (index < list.size())
    s += " (level " + std::to_string(list[index].level) + ", x " + std::to_string(list[index].x) + ", y " +
         std::to_string(list[index].y) + ")";
  return s;
}

namespace {

std::shared_ptr<const Scene> build_scene(const std::string& input, int profile, const Image& image) {
  Backend& cpu = reference_backend();
  auto sc = std::make_shared<Scene>();
  sc->input = input;
  sc->profile = profile;
  sc->image = &image;
  const FrontendSettings& s = profiles().at(static_cast<std::size_t>(profile)).settings;
  sc->tables = FrontendTables::build(s, image.width(), image.height());
  const FrontendTables& t = sc->tables;
  const int pitch0 = image.pitch_bytes() > image.width() ? image.pitch_bytes() : 0;
  sc->layout = PyramidLayout::make(t.level_sizes, 1, pitch0);
  sc->response_layout = PyramidLayout::make(t.level_sizes, 2);
  const auto pyramid_bytes = static_cast<std::size_t>(sc->layout.total_bytes);
  const Plane& l0 = sc->layout.levels[0];

  sc->level0.assign(pyramid_bytes, 0);
  for (int y = 0; y < image.height(); ++y)
    std::memcpy(sc->level0.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(l0.pitch),
                image.row(y), static_cast<std::size_t>(image.width()));
  auto pyramid = upload_vector(cpu, sc->level0);
  auto resize = upload_vector(cpu, t.resize.packed);
  cpu.build_pyramid(*pyramid, sc->layout, *resize, t.resize.level_offset);
  sc->pyramid = download_bytes(cpu, *pyramid, pyramid_bytes);

  auto lut = upload_vector(cpu, t.fast_lut);
  auto responses = poisoned(cpu, static_cast<std::size_t>(sc->response_layout.total_bytes));
  cpu.fast_crf(*pyramid, sc->layout, *lut, *responses, sc->response_layout,
               FastParams{s.fast_threshold, s.edge});
  sc->responses = download_bytes(cpu, *responses, static_cast<std::size_t>(sc->response_layout.total_bytes));

  const auto total_cells = static_cast<std::size_t>(t.cells.total_cells);
  auto cells = poisoned(cpu, total_cells * sizeof(Keypoint));
  cpu.cull_cells(*responses, sc->response_layout, t.cells, *cells);
  sc->cells = download_vector<Keypoint>(cpu, *cells, total_cells);
  cpu.pfa_filter(*cells, t.cells, PfaParams{t.scales_q16, l0.width, l0.height, s.pfa_window});
  sc->filtered = download_vector<Keypoint>(cpu, *cells, total_cells);

  auto dense = upload_vector(cpu, s.pfa ? sc->filtered : sc->cells);
  DeviceKeypoints list = empty_keypoints(cpu, t.cells.total_cells, 0);
  cpu.compact_keypoints(*dense, t.cells.total_cells, list.list);
  const std::uint32_t count = download_count(cpu, list.list);
  sc->keypoints = download_vector<Keypoint>(cpu, *list.items, count);

  auto boundaries = upload_vector(cpu, t.orientation_boundaries);
  cpu.orient(*pyramid, sc->layout, list.list, t.umax, *boundaries, s.orientation_bins);
  sc->oriented = download_vector<Keypoint>(cpu, *list.items, count);

  auto blurred = poisoned(cpu, pyramid_bytes);
  cpu.blur(*pyramid, sc->layout, *blurred, t.blur_taps);
  sc->blurred = download_bytes(cpu, *blurred, pyramid_bytes);

  auto pattern = upload_vector(cpu, t.orb_pattern);
  auto descriptors = poisoned(cpu, std::max<std::size_t>(count, 1) * sizeof(Descriptor));
  cpu.orb_describe(*blurred, sc->layout, list.list, *pattern, *descriptors);
  sc->descriptors = download_vector<Descriptor>(cpu, *descriptors, count);
  return sc;
}

}  // namespace

std::shared_ptr<const Scene> scene_for(const std::string& input, int profile, std::string& why) {
  // Cases run backend after backend for the same inputs, so a few recent scenes cover the reuse.
  static std::vector<std::shared_ptr<const Scene>> recent;
  for (const auto& s : recent)
    if (s->input == input && s->profile == profile) return s;
  const Image* image = input_image(input, why);
  if (image == nullptr) return nullptr;
  auto scene = build_scene(input, profile, *image);
  if (const char* v = std::getenv("PORTA_EQUIVALENCE_VERBOSE"); v != nullptr && *v != '\0' && *v != '0') {
    std::cout << "[ scene    ] " << input << " / " << profiles()[static_cast<std::size_t>(profile)].label
              << ": " << scene->keypoints.size() << " keypoints of " << scene->tables.cells.total_cells
              << " cells\n";
  }
  recent.insert(recent.begin(), scene);
  if (recent.size() > 6) recent.pop_back();
  return scene;
}

}  // namespace porta::eq
