// Fuzz target: trajectory files (TUM, KITTI with and without a times file, EuRoC CSV;
// slam/core/trajectory_io.cpp). The first byte picks the format (or detection); a KITTI input may
// carry a times.txt after a form feed. Documented failure: TrajectoryError.
#include <algorithm>

#include "fuzz_input.hpp"
#include "porta/slam/trajectory_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace porta::slam;
  namespace fz = porta::fuzz;
  if (size == 0) return 0;
  const std::uint8_t mode = data[0] % 5;
  std::span<const std::uint8_t> body(data + 1, size - 1);
  std::string times_path;
  if (mode == 4) {  // KITTI poses, then '\f', then times.txt
    const auto split = std::find(body.begin(), body.end(), std::uint8_t{'\f'});
    const std::size_t at = static_cast<std::size_t>(split - body.begin());
    times_path = fz::write_input(fz::scratch_folder() / "times.txt",
                                 split == body.end() ? std::span<const std::uint8_t>() : body.subspan(at + 1));
    body = body.first(at);
  }
  const std::string path = fz::write_input(fz::scratch_folder() / "trajectory.txt", body);
  try {
    Trajectory t;
    switch (mode) {
      case 0: t = read_trajectory(path); break;
      case 1: t = read_trajectory(path, TrajectoryFormat::tum); break;
      case 2: t = read_trajectory(path, TrajectoryFormat::kitti); break;
      case 3: t = read_trajectory(path, TrajectoryFormat::euroc); break;
      default: t = read_trajectory(path, TrajectoryFormat::kitti, times_path); break;
    }
    if (t.size() == 0) __builtin_trap();  // an empty trajectory must be an error, not a result
    (void)t.path_length_m();
  } catch (const TrajectoryError& e) {
    porta::fuzz::expected(e);
  }
  return 0;
}
