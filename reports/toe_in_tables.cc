#include "reports/toe_in_tables.h"

#include <sstream>

#include "fitting/format.h"

namespace owlcal::reports {

using fitting::FixedOrDash;

std::string ToeInMarkdown(const std::vector<fitting::ToeInSet>& sets, const fitting::ToeInServoFit& fit) {
  std::ostringstream md;
  md << "# Eye-pan servo maps from stereo calibrations at known PWM\n\n";
  md << "| set | Rx | Ry | Lx | Ly | relative yaw (deg) | sigma (deg) | fitted (deg) | residual (deg) | verdict |\n"
        "|---|---|---|---|---|---|---|---|---|---|\n";
  for (size_t i = 0; i < sets.size(); ++i) {
    const fitting::ToeInSet& s = sets[i];
    const fitting::ToeInSetResidual* r = nullptr;
    for (const auto& x : fit.residuals)
      if (x.set == static_cast<int>(i)) r = &x;
    md << "| " << s.name << " | " << FixedOrDash(s.rx_us, 0) << " | " << FixedOrDash(s.ry_us, 0) << " | "
       << FixedOrDash(s.lx_us, 0) << " | " << FixedOrDash(s.ly_us, 0) << " | "
       << (s.ok ? FixedOrDash(s.yaw_deg, 3) : "not used: " + s.message) << " | "
       << (s.ok ? FixedOrDash(s.yaw_sigma_deg, 3) : "") << " | " << (r ? FixedOrDash(r->predicted_deg, 3) : "") << " | "
       << (r ? FixedOrDash(r->residual_deg, 3) : "") << " | " << s.verdict << " |\n";
  }
  md << "\n";
  if (!fit.ok) {
    md << "**No fit**: " << fit.message << "\n";
  } else {
    md << "| parameter | value | sigma | unit | note |\n|---|---|---|---|---|\n";
    for (const auto& p : fit.parameters)
      md << "| " << p.name << " | " << FixedOrDash(p.value, 4) << " | " << FixedOrDash(p.sigma, 4) << " | " << p.unit
         << " | " << p.note << " |\n";
    md << "\n"
       << fit.num_sets << " sets, " << (fit.per_eye ? "one scale per eye" : "one scale for both eyes") << "; chi2/dof "
       << FixedOrDash(fit.chi2_per_dof, 2) << " (dof " << fit.dof << "), RMS residual "
       << FixedOrDash(fit.rms_residual_deg, 3) << " deg. The guide's nominal scale is 0.113 deg/us; Rx is "
       << FixedOrDash(100 * (fit.rx_deg_per_us / 0.113 - 1), 1) << " % from it, Lx "
       << FixedOrDash(100 * (fit.lx_deg_per_us / 0.113 - 1), 1) << " %.\n";
  }
  if (!fit.notes.empty()) {
    md << "\nNotes:\n";
    for (const auto& n : fit.notes) md << "- " << n << "\n";
  }
  return md.str();
}

std::string ToeInSetsCsv(const std::vector<fitting::ToeInSet>& sets, const fitting::ToeInServoFit& fit) {
  std::ostringstream c;
  c << "name,Rx,Ry,Lx,Ly,ok,yaw_deg,yaw_sigma_deg,pitch_deg,roll_deg,predicted_deg,residual_deg,z,verdict,message\n";
  for (size_t i = 0; i < sets.size(); ++i) {
    const fitting::ToeInSet& s = sets[i];
    const fitting::ToeInSetResidual* r = nullptr;
    for (const auto& x : fit.residuals)
      if (x.set == static_cast<int>(i)) r = &x;
    c << s.name << "," << s.rx_us << "," << s.ry_us << "," << s.lx_us << "," << s.ly_us << "," << (s.ok ? 1 : 0) << ","
      << (s.ok ? FixedOrDash(s.yaw_deg, 5) : "") << "," << (s.ok ? FixedOrDash(s.yaw_sigma_deg, 5) : "") << ","
      << (s.ok ? FixedOrDash(s.pitch_deg, 4) : "") << "," << (s.ok ? FixedOrDash(s.roll_deg, 4) : "") << ","
      << (r ? FixedOrDash(r->predicted_deg, 5) : "") << "," << (r ? FixedOrDash(r->residual_deg, 5) : "") << ","
      << (r ? FixedOrDash(r->z, 2) : "") << "," << s.verdict << ",\"" << s.message << "\"\n";
  }
  return c.str();
}

}  // namespace owlcal::reports
