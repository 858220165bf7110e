// Fuzz target: map files (slam/map/map_file_reader.cpp) and the place-recognition database they
// carry. With the first byte odd, every section's CRC-32 is recomputed before the file is read, so
// that mutations reach the content checks behind the checksums. Documented failures: MapFileError
// and PlaceDatabaseError.
#include <cstring>
#include <vector>

#include "fuzz_input.hpp"
#include "porta/slam/map.hpp"
#include "porta/slam/map_file.hpp"
#include "porta/slam/place_recognition.hpp"

namespace {

/// Walks the sections (tag, u64 size, payload, u32 CRC, after a 12-byte header) and rewrites each
/// CRC whose section lies inside the file.
void fix_checksums(std::vector<std::uint8_t>& file) {
  std::size_t at = 12;
  while (at + 12 <= file.size()) {
    std::uint64_t size = 0;
    std::memcpy(&size, file.data() + at + 4, 8);  // little-endian, as the writer (x86-64, aarch64)
    if (size > file.size() - at - 12 || file.size() - at - 12 - size < 4) return;
    const std::uint32_t crc = porta::slam::map_file_crc32(std::span(file).subspan(at + 12, size));
    std::memcpy(file.data() + at + 12 + size, &crc, 4);
    at += 12 + size + 4;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace porta::slam;
  namespace fz = porta::fuzz;
  if (size == 0) return 0;
  std::vector<std::uint8_t> file(data + 1, data + size);
  if (data[0] & 1) fix_checksums(file);
  const std::string path = fz::write_input(fz::scratch_folder() / "map.pmap", file);
  try {
    (void)read_map_info(path);
  } catch (const MapFileError& e) {
    porta::fuzz::expected(e);
  }
  try {
    Map map;
    const MapFileContents contents = load_map(path, map);
    if (!contents.place_database.empty()) (void)PlaceDatabase::deserialize(contents.place_database);
  } catch (const MapFileError& e) {
    porta::fuzz::expected(e);
  } catch (const PlaceDatabaseError& e) {
    porta::fuzz::expected(e);
  }
  return 0;
}
