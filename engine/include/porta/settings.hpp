// Frontend settings: one struct per pipeline, validated before use (never global).
#pragma once

#include <stdexcept>
#include <string>

namespace porta {

/// Thrown for a setting out of its allowed range; the message names the field and the range.
class SettingsError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

struct FrontendSettings {
  // Pyramid (DESIGN.md §3.2).
  int levels = 8;              ///< [1, 12]
  double scale_factor = 1.2;   ///< (1, 2]
  // FAST CRF with bounded rectification (§3.3).
  int fast_threshold = 20;     ///< epsilon, [1, 254]
  int min_arc = 9;             ///< Pmin, [1, 16]
  int max_arc = 13;            ///< Pmax, [Pmin, 16]; 16 = classic FAST
  int edge = 19;               ///< border skipped by detection, [19, 255]: the rotated ORB pattern
                               ///< reaches 18 px and the orientation patch 15 px from the keypoint
  // Feature culling (§3.4): level-0 cell size, scaled by 1/s^n per level.
  int cell_width = 32;         ///< [1, 1024]
  int cell_height = 32;        ///< [1, 1024]
  // Pyramidal feature aggregation (§3.5).
  bool pfa = true;
  int pfa_window = 3;          ///< q, odd, [1, 15]
  // Orientation (§3.6).
  int orientation_bins = 32;   ///< B, [4, 64]
  // Stereo matching (§3.9), in level-0 pixels.
  int stereo_min_disparity = 0;    ///< [0, max)
  int stereo_max_disparity = 128;  ///< (min, 4096]
  int stereo_max_hamming = 75;     ///< best distance must be below this, [1, 256]

  /// Throws SettingsError naming the first invalid field and its allowed range.
  void validate() const;
};

/// Largest image side the engine accepts (keeps all fixed-point products inside 32 bits).
inline constexpr int kMaxImageSide = 16384;

}  // namespace porta
