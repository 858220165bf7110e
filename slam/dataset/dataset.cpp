#include "porta/slam/dataset.hpp"

#if PORTA_DATASET_HAVE_OPENCV
#include <opencv2/core.hpp>
#endif

#include "dataset_internal.hpp"

namespace porta::slam {

std::optional<DatasetKind> parse_dataset_kind(std::string_view name) {
  if (name == "kitti") return DatasetKind::kitti;
  if (name == "euroc") return DatasetKind::euroc;
  if (name == "folder") return DatasetKind::folder;
  return std::nullopt;
}

const char* to_string(DatasetKind kind) {
  switch (kind) {
    case DatasetKind::kitti:
      return "kitti";
    case DatasetKind::euroc:
      return "euroc";
    case DatasetKind::folder:
      return "folder";
  }
  return "unknown";
}

namespace detail {

std::optional<SettingsFile> read_settings_option(const DatasetOptions& options) {
  if (options.settings_path.empty()) return std::nullopt;
  try {
    return read_settings_file(options.settings_path);
  } catch (const SettingsFileError& e) {
    fail(e.what());
  }
}

}  // namespace detail

std::unique_ptr<StereoDataset> open_dataset(DatasetKind kind, const std::string& path,
                                            const DatasetOptions& options) {
  if (path.empty()) detail::fail(std::string(to_string(kind)) + " dataset: no path given");
  const char* what = kind == DatasetKind::kitti   ? "KITTI dataset folder"
                     : kind == DatasetKind::euroc ? "EuRoC dataset folder"
                                                  : "stereo folder";
  detail::require_folder(path, what);
  // Every OpenCV step of the readers is wrapped where it is called (image decoding, rectification);
  // this names the dataset should one ever escape.
  try {
    switch (kind) {
      case DatasetKind::kitti:
        return detail::open_kitti(path, options);
      case DatasetKind::euroc:
        return detail::open_euroc(path, options);
      case DatasetKind::folder:
        return detail::open_folder(path, options);
    }
#if PORTA_DATASET_HAVE_OPENCV
  } catch (const cv::Exception& e) {
    detail::fail(std::string(what) + " " + detail::in_quotes(path) + ": a file in it could not be read (OpenCV: " +
                 e.err + ")");
#endif
  } catch (const std::bad_alloc&) {
    detail::fail(std::string(what) + " " + detail::in_quotes(path) + ": out of memory while opening it");
  }
  detail::fail("unknown dataset kind");
}

}  // namespace porta::slam
