#include "reports/calibration_check_tables.h"

#include <sstream>

#include "fitting/format.h"

namespace owlcal::reports {

std::string CalibrationCheckMarkdown(const evaluation::CalibrationCheck& c, const std::string& source) {
  std::ostringstream m;
  m << "# Calibration check\n\nCalibration: " << source << "\n\n";
  if (!c.ok) {
    m << "**No verdict**: " << c.message << "\n";
    return m.str();
  }
  m << "**Verdict: " << c.verdict << "**";
  if (!c.reasons.empty()) {
    m << "\n\n";
    for (const auto& r : c.reasons) m << "- " << r << "\n";
  } else {
    m << " (reprojection, epipolar error and ranging within the limits)\n";
  }
  m << "\nWhat moved (each parameter refitted alone; named when it alone explains most of the disagreement): "
    << (c.moved.empty() ? "nothing" : "") << "\n";
  for (const auto& s : c.moved) m << "- " << s << "\n";
  if (!c.calibration_has_covariance)
    m << "\nThe calibration file has no covariance: the z columns below use the refit's sigma alone.\n";
  m << "\n## With the calibration held fixed (" << c.num_pairs << " pairs, " << c.num_corners[0] << " + "
    << c.num_corners[1] << " corners)\n\n| measure | value | sigma |\n|---|---|---|\n"
    << "| reprojection RMS left (px) | " << fitting::FixedOrDash(c.rms_px[0], 3) << " | "
    << fitting::FixedOrDash(c.sigma_rms_px[0], 3) << " |\n"
    << "| reprojection RMS right (px) | " << fitting::FixedOrDash(c.rms_px[1], 3) << " | "
    << fitting::FixedOrDash(c.sigma_rms_px[1], 3) << " |\n"
    << "| reprojection RMS joint (px) | " << fitting::FixedOrDash(c.rms_joint_px, 3) << " | "
    << fitting::FixedOrDash(c.sigma_rms_joint_px, 3) << " |\n"
    << "| per-eye RMS, own board pose (px) | " << fitting::FixedOrDash(c.mono_rms_px[0], 3) << " / "
    << fitting::FixedOrDash(c.mono_rms_px[1], 3) << " | - |\n"
    << "| rectified mean dy (px) | " << fitting::FixedOrDash(c.epipolar_mean_dy_px, 3) << " | "
    << fitting::FixedOrDash(c.sigma_epipolar_mean_dy_px, 3) << " |\n"
    << "| rectified RMS / max dy (px) | " << fitting::FixedOrDash(c.epipolar_rms_dy_px, 3) << " / "
    << fitting::FixedOrDash(c.epipolar_max_dy_px, 3) << " | - |\n"
    << "| refit extrinsics: RMS (px) | " << fitting::FixedOrDash(c.refit_extrinsics_rms_px, 3) << " | - |\n"
    << "| refit fx fy cx cy + extrinsics: RMS, epipolar RMS (px) | " << fitting::FixedOrDash(c.refit_all_rms_px, 3)
    << ", " << fitting::FixedOrDash(c.refit_all_epipolar_rms_dy_px, 3) << " | corner sigma "
    << fitting::FixedOrDash(c.corner_sigma_px, 3) << " |\n"
    << "| range of a point at 1 m (m) | " << fitting::FixedOrDash(c.range_at_1m_m, 4) << " | "
    << fitting::FixedOrDash(c.sigma_range_at_1m_m, 4) << " |\n";
  m << "\n## Per view (calibration fixed)\n\n| frame | corners L/R | RMS L px | RMS R px | mean dy px "
       "|\n|---|---|---|---|---|\n";
  for (const auto& v : c.views)
    m << "| " << v.frame_index << " | " << v.num_corners[0] << "/" << v.num_corners[1] << " | "
      << fitting::FixedOrDash(v.rms_px[0], 3) << " | " << fitting::FixedOrDash(v.rms_px[1], 3) << " | "
      << fitting::FixedOrDash(v.mean_dy_px, 3) << " |\n";
  auto table = [&](const char* title, const std::vector<evaluation::CheckedParameter>& ps) {
    m << "\n## " << title
      << "\n\n| parameter | calibrated | refit | difference | sigma cal | sigma refit | z | moved |\n"
      << "|---|---|---|---|---|---|---|---|\n";
    for (const auto& p : ps)
      m << "| " << p.name << " | " << fitting::FixedOrDash(p.calibrated, 4) << " | " << fitting::FixedOrDash(p.refit, 4)
        << " | " << fitting::FixedOrDash(p.refit - p.calibrated, 4) << " | "
        << fitting::FixedOrDash(p.sigma_calibration, 4) << " | " << fitting::FixedOrDash(p.sigma_refit, 4) << " | "
        << fitting::FixedOrDash(p.z, 1) << " | " << (p.moved ? "yes" : "") << " |\n";
  };
  m << "\n## Each parameter refitted alone\n\n| parameter | change | share of the disagreement | chi2 |\n"
    << "|---|---|---|---|\n";
  for (const auto& d : c.single)
    m << "| " << d.name << " | " << fitting::FixedOrDash(d.change, 4) << " " << d.unit << " | "
      << fitting::FixedOrDash(100 * d.explained, 1) << " % | " << fitting::FixedOrDash(d.chi2, 1)
      << (d.significant ? "" : " (not significant)") << " |\n";
  table("Refit A: extrinsics only", c.extrinsics);
  table("Refit B: fx fy cx cy and extrinsics (distortion fixed)", c.all);
  if (!c.unpaired_frames.empty()) {
    m << "\nFrames without the board in both eyes (not used):";
    for (int f : c.unpaired_frames) m << " " << f;
    m << "\n";
  }
  return m.str();
}

}  // namespace owlcal::reports
