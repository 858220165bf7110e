// Shared by the dataset fuzz targets (fuzz_kitti.cpp, fuzz_euroc.cpp): the valid 64x48 images of
// the dataset folders the fuzzed text files sit in, and the split of one input into several files.
#pragma once

#include <algorithm>
#include <span>
#include <vector>

#include "fuzz_input.hpp"
#include "imageio/png_file.hpp"

namespace porta::fuzz {

/// Writes the same textured 64x48 gray PNG at each path (creating the folders).
inline void write_scaffold_pngs(const std::vector<fs::path>& paths) {
  std::vector<std::uint8_t> pixels(64 * 48);
  for (std::size_t i = 0; i < pixels.size(); ++i) pixels[i] = static_cast<std::uint8_t>((i * 37) ^ (i >> 3));
  for (const fs::path& path : paths) {
    fs::create_directories(path.parent_path());
    io::write_png_gray(path.string(), 64, 48, pixels.data(), 64);
  }
}

/// Splits `input` at form feeds into at most `max_parts` parts; the last part takes the rest.
inline std::vector<std::span<const std::uint8_t>> split_at_form_feeds(std::span<const std::uint8_t> input,
                                                                      std::size_t max_parts) {
  std::vector<std::span<const std::uint8_t>> parts;
  while (parts.size() + 1 < max_parts) {
    const auto split = std::find(input.begin(), input.end(), std::uint8_t{'\f'});
    if (split == input.end()) break;
    const std::size_t at = static_cast<std::size_t>(split - input.begin());
    parts.push_back(input.first(at));
    input = input.subspan(at + 1);
  }
  parts.push_back(input);
  return parts;
}

}  // namespace porta::fuzz
