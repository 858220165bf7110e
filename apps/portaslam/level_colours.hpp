// The colour of each pyramid level in portaslam's pictures, shared by the OpenCV drawing
// (annotate.cpp) and the plain one of a build without OpenCV (plain_picture.cpp).
#pragma once

#include <array>
#include <cstdint>

namespace porta::app {

/// Twelve well-separated hues, one per possible level, as {blue, green, red}.
inline constexpr std::array<std::array<std::uint8_t, 3>, 12> kLevelColoursBgr = {{
    {60, 60, 255}, {40, 160, 255}, {40, 230, 230}, {60, 220, 60}, {230, 200, 40}, {255, 110, 40},
    {230, 60, 200}, {150, 90, 255}, {170, 255, 170}, {255, 255, 120}, {120, 200, 255}, {255, 170, 220}}};

}  // namespace porta::app
