// Byte-for-byte comparison of kernel outputs, cpu against a backend under test, over meaningful
// elements only (plane pixels within width x height, never pitch padding; records up to the count).
// Each function returns nullopt when equal, else a report of the first differing element with its
// coordinates and both values, and how many elements differ.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "porta/keypoint.hpp"
#include "porta/layout.hpp"

namespace porta::eq {

using Mismatch = std::optional<std::string>;

/// Who produced each side, for the report ("cpu" and the backend under test).
struct Sides {
  std::string ref = "cpu";
  std::string got;
};

/// Names an index of a record array in a report, e.g. "cell 12 (level 0, cell row 1, col 3)".
using Locator = std::function<std::string(std::size_t)>;

/// Planes of `element_bytes` (1: uint8, 2: uint16) elements inside whole-buffer byte copies; each
/// plane's width x height elements are compared. `planes[i]` is reported as "level i", or as
/// `plane_name` when that is given (a single plane such as rectify's destination).
Mismatch compare_planes(const std::vector<std::uint8_t>& ref, const std::vector<std::uint8_t>& got,
                        const std::vector<Plane>& planes, int element_bytes, const Sides& sides,
                        const std::string& plane_name = {});

Mismatch compare_count(const std::string& what, std::int64_t ref, std::int64_t got, const Sides& sides);

/// Records, field by field: index, field name and both values of the first difference.
Mismatch compare_keypoints(const std::vector<Keypoint>& ref, const std::vector<Keypoint>& got,
                           const Sides& sides, const Locator& locate);
Mismatch compare_stereo_matches(const std::vector<StereoMatch>& ref, const std::vector<StereoMatch>& got,
                                const Sides& sides, const Locator& locate);
/// The `reserved` field is not compared (not part of the contract).
Mismatch compare_projection_results(const std::vector<ProjectionResult>& ref,
                                    const std::vector<ProjectionResult>& got, const Sides& sides,
                                    const Locator& locate);
/// Descriptors: the first differing descriptor, byte and bit, and the number of differing bits.
Mismatch compare_descriptors(const std::vector<Descriptor>& ref, const std::vector<Descriptor>& got,
                             const Sides& sides, const Locator& locate);

/// "{x 10, y 20, response 300, level 1, angle_bin 5}".
std::string format_keypoint(const Keypoint& k);

}  // namespace porta::eq
