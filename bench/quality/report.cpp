#include "quality/report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <opencv2/core/version.hpp>

#include "porta/json_text.hpp"

namespace porta::quality {

namespace {

std::string fixed(double v, int digits) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", digits, v);
  return buffer;
}
std::string percent(double fraction) { return fixed(100.0 * fraction, 1); }


// The sets in the order they were measured, each with its pairs.
std::vector<std::pair<std::string, std::vector<const OxfordPairResult*>>> by_set(
    const std::vector<OxfordPairResult>& pairs) {
  std::vector<std::pair<std::string, std::vector<const OxfordPairResult*>>> sets;
  for (const auto& p : pairs) {
    if (sets.empty() || sets.back().first != p.set) sets.push_back({p.set, {}});
    sets.back().second.push_back(&p);
  }
  return sets;
}

template <typename Get>
double mean_of(const std::vector<const OxfordPairResult*>& pairs, Get get) {
  if (pairs.empty()) return 0.0;
  double sum = 0.0;
  for (const auto* p : pairs) sum += get(*p);
  return sum / static_cast<double>(pairs.size());
}

std::vector<const OxfordPairResult*> all_of(const std::vector<OxfordPairResult>& pairs) {
  std::vector<const OxfordPairResult*> all;
  for (const auto& p : pairs) all.push_back(&p);
  return all;
}

struct PooledStereo {
  int left = 0, matches = 0, evaluated = 0, within_1px = 0, within_half_px = 0;
};
PooledStereo pool(const std::vector<StereoSceneResult>& scenes) {
  PooledStereo t;
  for (const auto& s : scenes) {
    t.left += s.accuracy.left_keypoints;
    t.matches += s.accuracy.matches;
    t.evaluated += s.accuracy.evaluated;
    t.within_1px += s.accuracy.within_1px;
    t.within_half_px += s.accuracy.within_half_px;
  }
  return t;
}
double ratio(int a, int b) { return b > 0 ? static_cast<double>(a) / b : 0.0; }

void settings_lines(std::ostream& out, const QualityReport& r) {
  const auto& s = r.settings;
  out << "- backend: " << r.backend << "\n"
      << "- data: `" << r.data_dir << "`\n"
      << "- PortaSLAM frontend settings (FrontendSettings defaults unless named): " << s.levels
      << " levels, scale " << s.scale_factor << ", FAST threshold " << s.fast_threshold << ", arc ["
      << s.min_arc << ", max_arc] with "
      << "max_arc 13 (bounded rectification) or 16 (classic FAST), edge " << s.edge << ", cells "
      << s.cell_width << "x" << s.cell_height << ", PFA " << (s.pfa ? "on" : "off") << " (window "
      << s.pfa_window << "), orientation bins " << s.orientation_bins << "\n"
      << "- OpenCV " << CV_VERSION << ": FAST-9/16 (threshold " << r.oxford_params.opencv_fast_threshold
      << ", non-max suppression on, single scale) keeping the N strongest; ORB (nfeatures N, " << s.levels
      << " levels, scale " << s.scale_factor << ", FAST threshold " << s.fast_threshold
      << ", Harris score, patch 31, edge 31)\n"
      << "- N = ours-bounded keypoint count on each image; ours-classic and ours-PFA-off keep their N "
         "strongest by FAST response (when they have more)\n"
      << "- wall time of the whole run: " << fixed(r.seconds, 1) << " s\n";
}

}  // namespace

void write_markdown(std::ostream& out, const QualityReport& r) {
  out << "# PortaSLAM quality on real data\n\n";
  settings_lines(out, r);

  if (!r.pairs.empty()) {
    const auto sets = by_set(r.pairs);
    const auto all = all_of(r.pairs);
    out << "\n## Corner repeatability (Oxford, epsilon " << fixed(r.oxford_params.repeat_epsilon_px, 1)
        << " px, img1 -> img2..img6)\n\n"
        << "Mean over the five pairs of each set, in percent. N = mean ours-bounded keypoints per image.\n";
    auto repeat_table = [&](bool symmetric) {
      out << "\n| set | N |";
      for (int d = 0; d < kOxfordDetectors; ++d) out << " " << detector_label(d) << " |";
      out << "\n|---|---:|";
      for (int d = 0; d < kOxfordDetectors; ++d) out << "---:|";
      out << "\n";
      auto row = [&](const std::string& name, const std::vector<const OxfordPairResult*>& ps) {
        const double n = mean_of(ps, [](const OxfordPairResult& p) {
          return 0.5 * (p.count_first[kOursBounded] + p.count_second[kOursBounded]);
        });
        out << "| " << name << " | " << fixed(n, 0) << " |";
        for (std::size_t d = 0; d < kOxfordDetectors; ++d)
          out << " " << percent(mean_of(ps, [d, symmetric](const OxfordPairResult& p) {
            return symmetric ? p.repeatability[d].symmetric_value : p.repeatability[d].value;
          })) << " |";
        out << "\n";
      };
      for (const auto& [name, ps] : sets) row(name, ps);
      row("**all**", all);
    };
    repeat_table(false);
    out << "\nSymmetric variant: a correspondence must also lie within "
        << fixed(r.oxford_params.repeat_epsilon_px, 1)
        << " px after back-projection into img1 (removes chance repeats where imgN is zoomed out):\n";
    repeat_table(true);

    out << "\nWhere the gap comes from: single-scale detectors on the same 32x32 cells (level 0 only). "
           "N1 = mean keypoints of img1 of ours with 1 level.\n\n| set | N1 |";
    for (int d = 0; d < kCullingDiagnostics; ++d) out << " " << diagnostic_label(d) << " |";
    out << "\n|---|---:|";
    for (int d = 0; d < kCullingDiagnostics; ++d) out << "---:|";
    out << "\n";
    auto diagnostic_row = [&](const std::string& name, const std::vector<const OxfordPairResult*>& ps) {
      out << "| " << name << " | "
          << fixed(mean_of(ps,
                           [](const OxfordPairResult& p) { return p.diagnostic_count_first[kOursOneLevel]; }),
                   0)
          << " |";
      for (std::size_t d = 0; d < kCullingDiagnostics; ++d)
        out << " " << percent(mean_of(ps, [d](const OxfordPairResult& p) {
          return p.diagnostic_repeatability[d].value;
        })) << " |";
      out << "\n";
    };
    for (const auto& [name, ps] : sets) diagnostic_row(name, ps);
    diagnostic_row("**all**", all);

    out << "\nPer pair (repeatability in percent; keypoints img1/imgN per detector):\n\n| pair |";
    for (int d = 0; d < kOxfordDetectors; ++d) out << " " << detector_label(d) << " |";
    out << "\n|---|";
    for (int d = 0; d < kOxfordDetectors; ++d) out << "---:|";
    out << "\n";
    for (const auto& p : r.pairs) {
      out << "| " << p.set << " 1-" << p.target << " |";
      for (std::size_t d = 0; d < kOxfordDetectors; ++d)
        out << " " << percent(p.repeatability[d].value) << " (" << p.count_first[d] << "/"
            << p.count_second[d] << ") |";
      out << "\n";
    }

    struct Method {
      const char* label;
      MatchingScore OxfordPairResult::*score;
    };
    const Method methods[] = {{"ours", &OxfordPairResult::ours_matching},
                              {"ours, PFA off", &OxfordPairResult::ours_no_pfa_matching},
                              {"OpenCV ORB", &OxfordPairResult::opencv_matching}};
    out << "\n## Descriptor matching (Oxford, mutual nearest Hamming neighbours, correct within "
        << fixed(r.oxford_params.correct_match_px, 1) << " px)\n\n"
        << "Matching score = correct matches / img1 keypoints in the common region; precision = correct / "
           "all "
           "mutual matches. Percent, mean over the five pairs of each set.\n\n| set |";
    for (const auto& m : methods) out << " " << m.label << " score | " << m.label << " precision |";
    out << "\n|---|";
    for (std::size_t k = 0; k < std::size(methods); ++k) out << "---:|---:|";
    out << "\n";
    auto match_row = [&](const std::string& name, const std::vector<const OxfordPairResult*>& ps) {
      out << "| " << name << " |";
      for (const auto& m : methods)
        out << " " << percent(mean_of(ps, [&](const OxfordPairResult& p) { return (p.*m.score).score; }))
            << " | "
            << percent(mean_of(ps, [&](const OxfordPairResult& p) { return (p.*m.score).precision; }))
            << " |";
      out << "\n";
    };
    for (const auto& [name, ps] : sets) match_row(name, ps);
    match_row("**all**", all);

    out << "\nPer pair: score, precision (correct / mutual matches / common img1 keypoints):\n\n| pair |";
    for (const auto& m : methods) out << " " << m.label << " |";
    out << "\n|---|";
    for (std::size_t k = 0; k < std::size(methods); ++k) out << "---:|";
    out << "\n";
    for (const auto& p : r.pairs) {
      out << "| " << p.set << " 1-" << p.target << " |";
      for (const auto& m : methods) {
        const MatchingScore& s = p.*m.score;
        out << " " << percent(s.score) << ", " << percent(s.precision) << " (" << s.correct_matches << "/"
            << s.mutual_matches << "/" << s.common_first << ") |";
      }
      out << "\n";
    }
  }

  if (!r.scenes.empty()) {
    const auto& s = r.stereo_settings;
    out << "\n## Sparse stereo accuracy (Middlebury, im2 left, im6 right, truth disp2)\n\n"
        << "Frontend::detect_stereo with disparities [" << s.stereo_min_disparity << ", "
        << s.stereo_max_disparity << "] px, Hamming below " << s.stereo_max_hamming
        << ". Each match is scored at its left keypoint's level-0 position rounded to the nearest pixel; "
           "matches on pixels of unknown truth (0) are not scored. Density = matches / left keypoints.\n\n"
        << "| scene | size | max true disparity | left keypoints | matches | density | scored | within 1 px "
           "| "
           "within 0.5 px | median abs error (px) |\n|---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const auto& sc : r.scenes) {
      const auto& a = sc.accuracy;
      out << "| " << sc.scene << " | " << sc.size.width << "x" << sc.size.height << " | "
          << fixed(sc.max_true_disparity_px, 2) << " | " << a.left_keypoints << " | " << a.matches << " | "
          << percent(a.density) << "% | " << a.evaluated << " | " << percent(a.fraction_within_1px) << "% | "
          << percent(a.fraction_within_half_px) << "% | " << fixed(a.median_abs_error_px, 3) << " |\n";
    }
    const PooledStereo t = pool(r.scenes);
    out << "| **all (pooled)** | | | " << t.left << " | " << t.matches << " | "
        << percent(ratio(t.matches, t.left)) << "% | " << t.evaluated << " | "
        << percent(ratio(t.within_1px, t.evaluated)) << "% | "
        << percent(ratio(t.within_half_px, t.evaluated)) << "% | |\n";

    // Pooled over the scenes, by the left keypoint's level: a level-n match is refined on the
    // level-n images, whose pixel is s^n level-0 pixels wide.
    std::vector<int> evaluated, within_1px, within_half_px;
    for (const auto& sc : r.scenes) {
      const auto& a = sc.accuracy;
      evaluated.resize(std::max(evaluated.size(), a.evaluated_by_level.size()), 0);
      within_1px.resize(evaluated.size(), 0);
      within_half_px.resize(evaluated.size(), 0);
      for (std::size_t l = 0; l < a.evaluated_by_level.size(); ++l) {
        evaluated[l] += a.evaluated_by_level[l];
        within_1px[l] += a.within_1px_by_level[l];
        within_half_px[l] += a.within_half_px_by_level[l];
      }
    }
    out << "\nBy the left keypoint's pyramid level (all scenes pooled; level pixel = " << s.scale_factor
        << "^level level-0 px):\n\n| level | level pixel (px) | scored matches | within 1 px | within 0.5 px "
           "|\n"
        << "|---:|---:|---:|---:|---:|\n";
    for (std::size_t l = 0; l < evaluated.size(); ++l)
      out << "| " << l << " | " << fixed(std::pow(s.scale_factor, static_cast<double>(l)), 2) << " | "
          << evaluated[l] << " | " << percent(ratio(within_1px[l], evaluated[l])) << "% | "
          << percent(ratio(within_half_px[l], evaluated[l])) << "% |\n";
  }
}

void write_json(std::ostream& out, const QualityReport& r) {
  const auto& s = r.settings;
  out << "{\n  \"backend\": " << json_string(r.backend) << ",\n  \"data_dir\": " << json_string(r.data_dir)
      << ",\n"
      << "  \"seconds\": " << fixed(r.seconds, 2) << ",\n"
      << "  \"settings\": {\"levels\": " << s.levels << ", \"scale_factor\": " << s.scale_factor
      << ", \"fast_threshold\": " << s.fast_threshold << ", \"min_arc\": " << s.min_arc
      << ", \"edge\": " << s.edge << ", \"cell_width\": " << s.cell_width
      << ", \"cell_height\": " << s.cell_height << ", \"pfa\": " << (s.pfa ? "true" : "false")
      << ", \"pfa_window\": " << s.pfa_window
      << ", \"stereo_min_disparity\": " << r.stereo_settings.stereo_min_disparity
      << ", \"stereo_max_disparity\": " << r.stereo_settings.stereo_max_disparity
      << ", \"stereo_max_hamming\": " << r.stereo_settings.stereo_max_hamming << "},\n"
      << "  \"repeat_epsilon_px\": " << r.oxford_params.repeat_epsilon_px
      << ",\n  \"correct_match_px\": " << r.oxford_params.correct_match_px << ",\n  \"detectors\": [";
  for (int d = 0; d < kOxfordDetectors; ++d) out << (d ? ", " : "") << json_string(detector_label(d));
  out << "],\n  \"oxford_pairs\": [";
  for (std::size_t i = 0; i < r.pairs.size(); ++i) {
    const auto& p = r.pairs[i];
    out << (i ? ",\n" : "\n") << "    {\"set\": " << json_string(p.set) << ", \"target\": " << p.target
        << ", \"repeatability\": [";
    for (std::size_t d = 0; d < kOxfordDetectors; ++d) {
      const auto& rep = p.repeatability[d];
      out << (d ? ", " : "") << "{\"value\": " << fixed(rep.value, 4) << ", \"repeated\": " << rep.repeated
          << ", \"symmetric_value\": " << fixed(rep.symmetric_value, 4)
          << ", \"repeated_symmetric\": " << rep.repeated_symmetric
          << ", \"common_first\": " << rep.common_first << ", \"common_second\": " << rep.common_second
          << ", \"count_first\": " << p.count_first[d] << ", \"count_second\": " << p.count_second[d] << "}";
    }
    out << "], \"single_scale_diagnostics\": [";
    for (std::size_t d = 0; d < kCullingDiagnostics; ++d)
      out << (d ? ", " : "") << "{\"detector\": " << json_string(diagnostic_label(static_cast<int>(d)))
          << ", \"value\": " << fixed(p.diagnostic_repeatability[d].value, 4)
          << ", \"count_first\": " << p.diagnostic_count_first[d] << "}";
    out << "], \"matching\": {";
    auto matching = [&](const char* name, const MatchingScore& m, bool last) {
      out << "\"" << name << "\": {\"score\": " << fixed(m.score, 4)
          << ", \"precision\": " << fixed(m.precision, 4) << ", \"correct\": " << m.correct_matches
          << ", \"mutual\": " << m.mutual_matches << ", \"common_first\": " << m.common_first
          << ", \"common_second\": " << m.common_second << "}" << (last ? "" : ", ");
    };
    matching("ours", p.ours_matching, false);
    matching("ours_no_pfa", p.ours_no_pfa_matching, false);
    matching("opencv_orb", p.opencv_matching, true);
    out << "}}";
  }
  out << "\n  ],\n  \"middlebury\": [";
  for (std::size_t i = 0; i < r.scenes.size(); ++i) {
    const auto& sc = r.scenes[i];
    const auto& a = sc.accuracy;
    out << (i ? ",\n" : "\n") << "    {\"scene\": " << json_string(sc.scene)
        << ", \"width\": " << sc.size.width << ", \"height\": " << sc.size.height
        << ", \"max_true_disparity\": " << fixed(sc.max_true_disparity_px, 3)
        << ", \"left_keypoints\": " << a.left_keypoints << ", \"right_keypoints\": " << a.right_keypoints
        << ", \"matches\": " << a.matches << ", \"density\": " << fixed(a.density, 4)
        << ", \"evaluated\": " << a.evaluated << ", \"within_1px\": " << a.within_1px
        << ", \"within_half_px\": " << a.within_half_px
        << ", \"fraction_within_1px\": " << fixed(a.fraction_within_1px, 4)
        << ", \"fraction_within_half_px\": " << fixed(a.fraction_within_half_px, 4)
        << ", \"median_abs_error_px\": " << fixed(a.median_abs_error_px, 4)
        << ", \"fractional_disparities\": " << a.fractional_disparities << ", \"evaluated_by_level\": [";
    for (std::size_t l = 0; l < a.evaluated_by_level.size(); ++l)
      out << (l ? ", " : "") << a.evaluated_by_level[l];
    out << "], \"within_1px_by_level\": [";
    for (std::size_t l = 0; l < a.within_1px_by_level.size(); ++l)
      out << (l ? ", " : "") << a.within_1px_by_level[l];
    out << "], \"within_half_px_by_level\": [";
    for (std::size_t l = 0; l < a.within_half_px_by_level.size(); ++l)
      out << (l ? ", " : "") << a.within_half_px_by_level[l];
    out << "]}";
  }
  out << "\n  ]\n}\n";
}

}  // namespace porta::quality
