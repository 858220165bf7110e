// Inputs of the equivalence suite: named images (random, flat, saturated, checkerboards, smooth
// textures, shifted views for stereo, and the real photographs of ../shared/data), the settings
// profiles that between them take every swept value, and the cpu-made pipeline states ("scenes")
// that feed each kernel realistic inputs.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "porta/image.hpp"
#include "porta/keypoint.hpp"
#include "porta/layout.hpp"
#include "porta/settings.hpp"
#include "porta/tables.hpp"

namespace porta::eq {

// ---- Images --------------------------------------------------------------------------------------

/// The named image (made, or loaded from the shared data, once and then kept). Null when it cannot
/// be had, with `why` saying so (data folder absent, or no image loader in this build).
const Image* input_image(const std::string& name, std::string& why);
/// What the image is, e.g. "uniform random 333x257 (pitch 346, seed 3)".
std::string describe_input(const std::string& name);
/// Every name the catalogue knows (for checks of the case lists).
std::vector<std::string> input_names();

// ---- Settings ------------------------------------------------------------------------------------

struct Profile {
  std::string label;  ///< identifier characters only, e.g. "L12_c48_nopfa_t20_arc16_b12"
  FrontendSettings settings;
};
/// Between them: levels 1, 4, 8, 12; cells 8, 16, 32, 48, 64 and 16x40; PFA on and off (windows 3
/// and 5); FAST threshold 7, 20, 40; max arc 13 and 16; orientation bins 32 and 12; scale 1.2, 1.5
/// and 2; edge 19 and 31; several stereo disparity ranges and Hamming bounds.
const std::vector<Profile>& profiles();
/// All of a profile's settings in words, for failure messages.
std::string describe_settings(const FrontendSettings& s);

// ---- Scenes --------------------------------------------------------------------------------------

/// The pipeline state of one image under one profile, made by the cpu reference, stage by stage:
/// the input of each kernel is the output of the one before.
struct Scene {
  std::string input;
  int profile = 0;
  const Image* image = nullptr;
  FrontendTables tables;
  PyramidLayout layout;                 ///< uint8; level 0 keeps the image's pitch when that is padded
  PyramidLayout response_layout;        ///< uint16, aligned pitches (so differs from `layout`)
  std::vector<std::uint8_t> level0;     ///< pyramid buffer with only level 0 written
  std::vector<std::uint8_t> pyramid;    ///< after build_pyramid
  std::vector<std::uint8_t> responses;  ///< after fast_crf
  std::vector<Keypoint> cells;          ///< after cull_cells: the dense cell array
  std::vector<Keypoint> filtered;       ///< after pfa_filter (window of the profile) of `cells`
  std::vector<Keypoint> keypoints;      ///< compacted: from `filtered` when PFA is on, else `cells`
  std::vector<Keypoint> oriented;       ///< after orient
  std::vector<std::uint8_t> blurred;    ///< after blur
  std::vector<Descriptor> descriptors;  ///< after orb_describe

  const FrontendSettings& settings() const { return tables.settings; }
  /// "cell 123 (level 1, row 3, col 4)" for an index of the dense cell array.
  std::string locate_cell(std::size_t index) const;
};

/// The scene of `input` under profile `profile` (a few recent ones are kept). Null with `why` set
/// when the image cannot be had.
std::shared_ptr<const Scene> scene_for(const std::string& input, int profile, std::string& why);

/// "keypoint 17 (level 1, x 40, y 33)" for an index of a keypoint list.
std::string locate_keypoint(const std::vector<Keypoint>& list, std::size_t index);

}  // namespace porta::eq
