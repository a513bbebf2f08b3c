#include "reports/verdict_tables.h"

#include <sstream>

#include "fitting/format.h"

namespace owlcal::reports {

using fitting::FixedOrDash;

namespace {
const char* kEye[2] = {"left", "right"};
}  // namespace

Table SetVerdictEyeTable(const evaluation::SetVerdict& v) {
  const std::string range = v.judged_range_m > 0 ? FixedOrDash(v.judged_range_m, 2) + " m" : "infinity";
  Table t{"set_verdict_eyes",
          "",
          {"eye",
           "corner noise (px)",
           "projection sigma at " + range + ", working region p90 (px)",
           "trusted: working region",
           "trusted: image",
           "projection sigma at infinity, working region p90 (px)",
           "at the centre (px)",
           "sigma f / f",
           "sigma c (px)",
           "halves apart, working region p90 (px)",
           "halves' f differ",
           "sigma optimistic by"},
          {}};
  for (int e = 0; e < 2; ++e) {
    const evaluation::EyeVerdictMetrics& m = v.eye[e];
    t.rows.push_back({kEye[e],
                      FixedOrDash(m.noise_px, 3),
                      m.at_range.ok ? FixedOrDash(m.working_p90_range_px, 3) : "-",
                      m.at_range.ok ? FixedOrDash(100 * m.trusted_working_fraction, 0) + " %" : "-",
                      m.at_range.ok ? FixedOrDash(100 * m.trusted_fraction, 0) + " %" : "-",
                      m.at_infinity.ok ? FixedOrDash(m.working_p90_px, 3) : "-",
                      m.at_infinity.ok ? FixedOrDash(m.at_infinity.centre_px, 3) : "-",
                      m.at_infinity.ok ? FixedOrDash(100 * m.relative_focal_sigma, 3) + " %" : "-",
                      m.at_infinity.ok ? FixedOrDash(m.principal_sigma_px, 2) : "-",
                      m.halves.ok ? FixedOrDash(m.halves_working_p90_px, 3) : "-",
                      v.split ? FixedOrDash(100 * m.half_focal_diff, 2) + " %" : "-",
                      m.covariance_scale > 0 ? "x " + FixedOrDash(m.covariance_scale, 1) : "-"});
  }
  return t;
}

std::string SetVerdictMarkdown(const evaluation::SetVerdict& v) {
  std::ostringstream md;
  md << "Verdict: **" << v.status << "**";
  if (v.status == "good")
    md << " (the set pins down every parameter to the accuracy below, and two halves of it agree)";
  md << "\n\n";
  if (v.rig_note.empty())
    md << "Rig: " << v.rig.name << " (the checks that depend on the rig name it).\n\n";
  else
    md << "R" << v.rig_note.substr(1) << ".\n\n";
  if (!v.reasons.empty()) {
    md << "Why:\n";
    for (const auto& r : v.reasons) md << "- " << r << "\n";
    md << "\n";
  }
  if (!v.advice.empty()) {
    md << "Views to add:\n";
    for (const auto& a : v.advice) md << "- " << a << "\n";
    md << "\n";
  }
  const std::string range = v.judged_range_m > 0 ? FixedOrDash(v.judged_range_m, 2) + " m" : "infinity";
  md << ToMarkdown(SetVerdictEyeTable(v));
  md << "\nTrusted: where the predicted projection uncertainty at " << range << " is below "
     << FixedOrDash(v.trust_threshold_noise, 1) << " x the eye's corner noise; working region: within "
     << FixedOrDash(100 * v.working_radius_fraction, 0) << " % of the half-diagonal from the centre.\n";
  md << "\n"
     << v.num_pairs << " pairs; "
     << (v.split ? "halves calibrated alone and compared" : "not split: " + v.split_message) << ".\n";
  return md.str();
}

}  // namespace owlcal::reports
