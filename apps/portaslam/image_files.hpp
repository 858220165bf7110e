// Reading input images for the CLI: any format OpenCV decodes (PNG only, through libpng, in a build
// without OpenCV), converted to 8-bit gray, with an error that names the file and the problem
// (missing, not an image, too large) instead of an empty image that fails later.
#pragma once

#include <string>

#include "porta/image.hpp"

namespace porta::app {

struct LoadedImage {
  Image gray;
  std::string conversion;  ///< what was done to make it 8-bit gray, empty when it already was
};

/// Throws CliError: "cannot open image 'P': no such file", "... is a directory",
/// "cannot decode image 'P': not an image file OpenCV can read" (without OpenCV: "...: not a PNG
/// file (no PNG signature) ..." or "...: corrupt or truncated PNG (libpng: ...)"), or a size
/// beyond kMaxImageSide.
LoadedImage load_gray_image(const std::string& path);

}  // namespace porta::app
