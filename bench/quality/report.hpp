// The quality report: markdown tables for people (docs/QUALITY.md) and JSON for tools.
#pragma once

#include <ostream>
#include <string>
#include <vector>

#include "porta/settings.hpp"
#include "quality/experiments.hpp"

namespace porta::quality {

struct QualityReport {
  std::string backend;  ///< name and device
  std::string data_dir;
  FrontendSettings settings;  ///< the Oxford (ours-bounded) settings
  FrontendSettings stereo_settings;
  OxfordParams oxford_params;
  std::vector<OxfordPairResult> pairs;  ///< in set order, img2..img6 within a set
  std::vector<StereoSceneResult> scenes;
  double seconds = 0.0;
};

void write_markdown(std::ostream& out, const QualityReport& report);
void write_json(std::ostream& out, const QualityReport& report);

}  // namespace porta::quality
