// A text file embedded into the library at build time (cmake/EmbedText.cmake): device sources
// are build artefacts, never looked up on disk at run time.
#pragma once

namespace porta {

struct EmbeddedText {
  const char* name;  ///< file name without extension, e.g. "detect"
  const char* text;
};

}  // namespace porta
