// A SPIR-V module embedded into the library at build time (cmake/EmbedSpirv.cmake): shaders are
// build artefacts, never looked up on disk at run time (STYLE.md item 4).
#pragma once

#include <cstddef>
#include <cstdint>

namespace porta::vulkan {

struct EmbeddedSpirv {
  const char* name;            ///< file name without extension, e.g. "fast_crf"
  const std::uint32_t* words;  ///< the module, in host byte order
  std::size_t word_count;
};

/// Generated from shaders/vulkan/*.comp.
extern const EmbeddedSpirv kEmbeddedSpirv[];
extern const int kEmbeddedSpirvCount;

}  // namespace porta::vulkan
