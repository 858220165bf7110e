#include "equivalence/compare.hpp"

#include <algorithm>
#include <bit>
#include <cstring>
#include <map>
#include <sstream>

namespace porta::eq {

namespace {

std::string hex_byte(std::uint8_t b) {
  static const char* digits = "0123456789abcdef";
  return std::string("0x") + digits[b >> 4] + digits[b & 15];
}

/// A record field: its name and how to read it as an integer.
template <typename T>
struct Field {
  const char* name;
  std::int64_t (*get)(const T&);
};

template <typename T>
std::string format_record(const T& r, const std::vector<Field<T>>& fields) {
  std::string s = "{";
  for (std::size_t i = 0; i < fields.size(); ++i)
    s += (i ? ", " : "") + std::string(fields[i].name) + " " + std::to_string(fields[i].get(r));
  return s + "}";
}

/// "the lists differ in length: cpu 1469 keypoints, opencl 1463; " (empty when equal), then
/// whether the common prefix agrees.
std::string length_note(std::size_t ref, std::size_t got, const char* nouns, const Sides& sides) {
  if (ref == got) return {};
  return "the lists differ in length: " + sides.ref + " " + std::to_string(ref) + " " + nouns + ", " +
         sides.got + " " + std::to_string(got) + "; ";
}

template <typename T>
Mismatch compare_records(const std::vector<T>& ref, const std::vector<T>& got,
                         const std::vector<Field<T>>& fields, const char* nouns, const Sides& sides,
                         const Locator& locate) {
  const std::size_t n = std::min(ref.size(), got.size());
  std::size_t differing = 0, first = 0;
  std::map<std::string, std::size_t> per_field;
  const Field<T>* first_field = nullptr;
  for (std::size_t i = 0; i < n; ++i) {
    bool differs = false;
    for (const Field<T>& f : fields) {
      if (f.get(ref[i]) == f.get(got[i])) continue;
      ++per_field[f.name];
      if (!differs && differing == 0) {
        first = i;
        first_field = &f;
      }
      differs = true;
    }
    differing += differs ? 1 : 0;
  }
  const std::string length = length_note(ref.size(), got.size(), nouns, sides);
  if (differing == 0) {
    if (length.empty()) return std::nullopt;
    return length + "the " + std::to_string(n) + " in common are identical";
  }
  std::ostringstream o;
  if (!length.empty()) o << length << "comparing the " << n << " in common\n  ";
  o << "first difference: " << locate(first) << ", field " << first_field->name << ": " << sides.ref << " "
    << first_field->get(ref[first]) << ", " << sides.got << " " << first_field->get(got[first]) << "\n    "
    << sides.ref << " " << format_record(ref[first], fields) << "\n    " << sides.got << " "
    << format_record(got[first], fields) << "\n  " << differing << " of " << n << " " << nouns
    << " differ (by field:";
  for (const auto& [name, k] : per_field) o << " " << name << " " << k;
  o << ")";
  if (!length.empty()) o << "; after the first difference the lists may be shifted against each other";
  return o.str();
}

const std::vector<Field<Keypoint>>& keypoint_fields() {
  static const std::vector<Field<Keypoint>> f = {
      {"x", [](const Keypoint& k) -> std::int64_t { return k.x; }},
      {"y", [](const Keypoint& k) -> std::int64_t { return k.y; }},
      {"response", [](const Keypoint& k) -> std::int64_t { return k.response; }},
      {"level", [](const Keypoint& k) -> std::int64_t { return k.level; }},
      {"angle_bin", [](const Keypoint& k) -> std::int64_t { return k.angle_bin; }},
  };
  return f;
}

}  // namespace

std::string format_keypoint(const Keypoint& k) { return format_record(k, keypoint_fields()); }

Mismatch compare_planes(const std::vector<std::uint8_t>& ref, const std::vector<std::uint8_t>& got,
                        const std::vector<Plane>& planes, int element_bytes, const Sides& sides,
                        const std::string& plane_name) {
  auto read = [&](const std::vector<std::uint8_t>& bytes, std::size_t at) -> std::int64_t {
    if (element_bytes == 1) return bytes[at];
    std::uint16_t v = 0;
    std::memcpy(&v, bytes.data() + at, sizeof(v));
    return v;
  };
  std::size_t total = 0, differing = 0;
  std::ostringstream first;
  std::map<int, std::size_t> per_level;
  for (std::size_t n = 0; n < planes.size(); ++n) {
    const Plane& p = planes[n];
    const int level = static_cast<int>(n);
    const std::string where = plane_name.empty() ? "level " + std::to_string(level) : plane_name;
    for (int y = 0; y < p.height; ++y) {
      for (int x = 0; x < p.width; ++x) {
        const auto at = static_cast<std::size_t>(
            p.offset_bytes + (static_cast<std::int64_t>(y) * p.pitch + x) * element_bytes);
        ++total;
        if (at + static_cast<std::size_t>(element_bytes) > ref.size() ||
            at + static_cast<std::size_t>(element_bytes) > got.size())
          return where + " reaches past the downloaded bytes (" + std::to_string(ref.size()) +
                 "): a harness bug";
        const std::int64_t a = read(ref, at), b = read(got, at);
        if (a == b) continue;
        if (differing == 0)
          first << "first difference: " << where << ", x " << x << ", y " << y << " (of " << p.width << "x"
                << p.height << ", pitch " << p.pitch << "): " << sides.ref << " " << a << ", " << sides.got
                << " " << b;
        ++differing;
        ++per_level[level];
      }
    }
  }
  if (differing == 0) return std::nullopt;
  first << "\n  " << differing << " of " << total << " elements differ";
  if (plane_name.empty()) {
    first << " (by level:";
    for (const auto& [level, n] : per_level) first << " " << level << ": " << n;
    first << ")";
  }
  return first.str();
}

Mismatch compare_count(const std::string& what, std::int64_t ref, std::int64_t got, const Sides& sides) {
  if (ref == got) return std::nullopt;
  return what + " differs: " + sides.ref + " " + std::to_string(ref) + ", " + sides.got + " " +
         std::to_string(got);
}

Mismatch compare_keypoints(const std::vector<Keypoint>& ref, const std::vector<Keypoint>& got,
                           const Sides& sides, const Locator& locate) {
  return compare_records(ref, got, keypoint_fields(), "keypoints", sides, locate);
}

Mismatch compare_stereo_matches(const std::vector<StereoMatch>& ref, const std::vector<StereoMatch>& got,
                                const Sides& sides, const Locator& locate) {
  static const std::vector<Field<StereoMatch>> fields = {
      {"disparity_q8", [](const StereoMatch& m) -> std::int64_t { return m.disparity_q8; }},
      {"right_index", [](const StereoMatch& m) -> std::int64_t { return m.right_index; }},
  };
  return compare_records(ref, got, fields, "matches", sides, locate);
}

Mismatch compare_projection_results(const std::vector<ProjectionResult>& ref,
                                    const std::vector<ProjectionResult>& got, const Sides& sides,
                                    const Locator& locate) {
  static const std::vector<Field<ProjectionResult>> fields = {
      {"best_index", [](const ProjectionResult& r) -> std::int64_t { return r.best_index; }},
      {"best_distance", [](const ProjectionResult& r) -> std::int64_t { return r.best_distance; }},
      {"second_distance", [](const ProjectionResult& r) -> std::int64_t { return r.second_distance; }},
  };
  return compare_records(ref, got, fields, "results", sides, locate);
}

Mismatch compare_descriptors(const std::vector<Descriptor>& ref, const std::vector<Descriptor>& got,
                             const Sides& sides, const Locator& locate) {
  const std::size_t n = std::min(ref.size(), got.size());
  std::size_t differing = 0, bits = 0;
  std::ostringstream first;
  for (std::size_t i = 0; i < n; ++i) {
    bool differs = false;
    for (std::size_t byte = 0; byte < 32; ++byte) {
      const auto x = static_cast<std::uint8_t>(ref[i].bytes[byte] ^ got[i].bytes[byte]);
      if (x == 0) continue;
      bits += static_cast<std::size_t>(std::popcount(x));
      if (differing == 0 && !differs) {
        const int bit = std::countr_zero(x);
        first << "first difference: descriptor of " << locate(i) << ", byte " << byte << ", bit " << bit
              << " (test pair " << byte * 8 + static_cast<std::size_t>(bit) << " of 256): " << sides.ref
              << " " << hex_byte(ref[i].bytes[byte]) << ", " << sides.got << " "
              << hex_byte(got[i].bytes[byte]);
      }
      differs = true;
    }
    differing += differs ? 1 : 0;
  }
  const std::string length = length_note(ref.size(), got.size(), "descriptors", sides);
  if (differing == 0) {
    if (length.empty()) return std::nullopt;
    return length + "the " + std::to_string(n) + " in common are identical";
  }
  first << "\n  " << differing << " of " << n << " descriptors differ (" << bits << " bits in all)";
  return (length.empty() ? std::string{} : length + "comparing the " + std::to_string(n) + " in common\n  ") +
         first.str();
}

}  // namespace porta::eq
