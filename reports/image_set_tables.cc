#include "reports/image_set_tables.h"

#include <sstream>

#include "fitting/format.h"

namespace owlcal::reports {

using fitting::FixedOrDash;
using fitting::RangeMeasurement;

std::string ImageSetReportMarkdown(const fitting::ImageSetCalibration& c, const std::vector<std::string>& keys) {
  std::ostringstream md;
  md << "# Stereo calibration from images\n\n";
  if (c.verdict.empty()) {
    md << "Verdict: the set determines every reported parameter.\n\n";
  } else {
    md << "Verdict: **poor set**. What it cannot determine:\n";
    for (const auto& v : c.verdict) md << "- " << v << "\n";
    md << "\n";
  }
  md << "Pairs used: " << c.fit.paired_frames.size() << "; RMS left " << FixedOrDash(c.fit.rms_px[0], 3) << " px, right "
     << FixedOrDash(c.fit.rms_px[1], 3) << " px, joint " << FixedOrDash(c.fit.rms_joint_px, 3) << " px; rectified |dy| mean "
     << FixedOrDash(c.fit.rectified_dy_mean_px, 3) << " px, max " << FixedOrDash(c.fit.rectified_dy_max_px, 3) << " px.\n\n";
  md << "| parameter | value | sigma | unit | note |\n|---|---|---|---|---|\n";
  for (const auto& p : c.result.parameters)
    md << "| " << p.name << " | " << FixedOrDash(p.value, 4) << " | " << (p.determined ? FixedOrDash(p.sigma, 4) : "not determined")
       << " | " << p.unit << " | " << p.note << " |\n";
  const char* eye_name[2] = {"left", "right"};
  for (int e = 0; e < 2; ++e) {
    const fitting::EyeCoverage& cov = c.coverage[e];
    md << "\n## " << eye_name[e] << " eye: coverage " << FixedOrDash(100 * cov.grid_fraction, 0) << " % of cells, radius "
       << FixedOrDash(100 * cov.max_radius_fraction, 0) << " %, tilt up to " << FixedOrDash(cov.max_tilt_deg, 1)
       << " deg, orientation spread " << FixedOrDash(cov.spread_deg, 1) << " deg\n\n| frame | pair | RMS (px) | tilt (deg) |\n"
       << "|---|---|---|---|\n";
    const fitting::IntrinsicsFit& f = c.fit.per_eye[e];
    for (size_t i = 0; i < f.frame_indices.size(); ++i) {
      const int fr = f.frame_indices[i];
      md << "| " << fr << " | " << (fr >= 0 && fr < static_cast<int>(keys.size()) ? keys[fr] : "") << " | "
         << (i < f.view_rms_px.size() ? FixedOrDash(f.view_rms_px[i], 3) : "-") << " | "
         << (i < cov.tilt_deg.size() ? FixedOrDash(cov.tilt_deg[i], 1) : "-") << " |\n";
    }
  }
  return md.str();
}

std::string RangeTableCsv(const std::vector<RangeMeasurement>& m) {
  std::ostringstream c;
  c << "name,true_cm,range_cm,error_cm,error_pct,sigma_cm,sigma_calib_cm,sigma_match_cm,z,disparity_px,"
       "sigma_disparity_px,dy_px,ncc,second_ncc,ray_gap_mm,ok,message\n";
  for (const auto& r : m) {
    c << r.name << "," << FixedOrDash(r.true_m * 100, 2) << "," << (r.ok ? FixedOrDash(r.range_m * 100, 3) : "") << ","
      << (r.ok ? FixedOrDash(r.error_m() * 100, 3) : "") << "," << (r.ok ? FixedOrDash(100 * r.error_m() / r.true_m, 3) : "") << ","
      << (r.ok ? FixedOrDash(r.sigma_m * 100, 3) : "") << "," << (r.ok ? FixedOrDash(r.sigma_calib_m * 100, 3) : "") << ","
      << (r.ok ? FixedOrDash(r.sigma_match_m * 100, 3) : "") << "," << (r.ok ? FixedOrDash(r.error_m() / r.error_sigma_m(), 2) : "") << ","
      << FixedOrDash(r.match.disparity_px, 3) << "," << FixedOrDash(r.match.sigma_disparity_px, 3) << ","
      << FixedOrDash(r.match.dy_px, 2) << "," << FixedOrDash(r.match.ncc, 3) << "," << FixedOrDash(r.match.second_ncc, 3) << ","
      << FixedOrDash(r.ray_gap_m * 1000, 2) << "," << (r.ok ? 1 : 0) << ",\"" << r.message << "\"\n";
  }
  return c.str();
}

std::string RangeTableMarkdown(const std::vector<RangeMeasurement>& m, const fitting::RangeSummary& s, const std::string& title) {
  std::ostringstream md;
  md << "# " << title << "\n\n"
     << "| pair | true (cm) | range (cm) | error (%) | sigma (cm) | sigma calib / match (cm) | truth sigma (cm) | "
        "error/sigma | disparity (px) | NCC |\n|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& r : m) {
    if (!r.ok) {
      md << "| " << r.name << " | " << FixedOrDash(r.true_m * 100, 1) << " | not ranged: " << r.message
         << " | | | | | | | |\n";
      continue;
    }
    md << "| " << r.name << " | " << FixedOrDash(r.true_m * 100, 1) << " | " << FixedOrDash(r.range_m * 100, 2) << " | "
       << FixedOrDash(100 * r.error_m() / r.true_m, 2) << " | " << FixedOrDash(r.sigma_m * 100, 2) << " | "
       << FixedOrDash(r.sigma_calib_m * 100, 2) << " / " << FixedOrDash(r.sigma_match_m * 100, 2) << " | "
       << FixedOrDash(r.truth_sigma_m * 100, 2) << " | " << FixedOrDash(r.error_m() / r.error_sigma_m(), 2) << " | " << FixedOrDash(r.match.disparity_px, 2) << " | " << FixedOrDash(r.match.ncc, 3)
       << " |\n";
  }
  md << "\nRanged " << s.num_ranged << "/" << s.num_rows << "; mean |error| " << FixedOrDash(100 * s.mean_abs_rel, 2)
     << " %, max " << FixedOrDash(100 * s.max_abs_rel, 2) << " %; max |error|/sigma " << FixedOrDash(s.max_abs_z, 2) << "; "
     << s.num_outside_3sigma << " outside +-3 sigma (error/sigma uses sqrt(sigma^2 + truth sigma^2)).\n";
  return md.str();
}

}  // namespace owlcal::reports
