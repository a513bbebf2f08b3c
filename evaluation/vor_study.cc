#include "evaluation/vor_study.h"

#include <algorithm>

#include "evaluation/study_cells.h"
#include "models/head_kinematics.h"

namespace owlcal::evaluation {

std::vector<const VorFrame*> internal::SelectVorFrames(const std::vector<VorFrame>& frames, int trial, int eye) {
  std::vector<const VorFrame*> out;
  for (const VorFrame& f : frames)
    if (f.trial == trial && f.eye == eye) out.push_back(&f);
  std::sort(out.begin(), out.end(), [](const VorFrame* a, const VorFrame* b) { return a->k < b->k; });
  return out;
}

nlohmann::json VorStudyJson(const VorStudy& s) {
  nlohmann::json j = TrialStudyHeaderJson(s);
  auto gain = [](const fitting::VorGain& g) {
    nlohmann::json o = {{"ok", g.ok}};
    if (!g.ok) {
      o["reason"] = g.reason;
      return o;
    }
    o["gain"] = g.gain;
    o["gain_sigma"] = g.gain_sigma;
    o["lag_deg"] = g.lag_deg;
    o["lag_sigma_deg"] = g.lag_sigma_deg;
    o["lag_ms"] = g.lag_ms;
    o["lag_sigma_ms"] = g.lag_sigma_ms;
    return o;
  };
  auto slip = [](const fitting::SlipStats& x) {
    return nlohmann::json{{"samples", x.num_samples},
                          {"rms_px", x.rms_px},
                          {"peak_px", x.peak_px},
                          {"rms_px_per_s", x.rms_px_per_s},
                          {"peak_px_per_s", x.peak_px_per_s},
                          {"rms_deg_per_s", x.rms_deg_per_s},
                          {"peak_deg_per_s", x.peak_deg_per_s}};
  };
  j["trials"] = nlohmann::json::array();
  for (const VorTrialEye& r : s.results) {
    nlohmann::json o = {{"trial", r.trial},
                        {"profile", r.profile},
                        {"frequency_hz", r.frequency_hz},
                        {"amplitude_deg", r.amplitude_deg},
                        {"condition", r.condition},
                        {"eye", models::kEyeNames[r.eye]},
                        {"status", r.status},
                        {"reason", r.reason},
                        {"frames", r.num_frames},
                        {"found", r.num_found},
                        {"slip", slip(r.slip)}};
    if (r.true_slip) o["true_slip"] = slip(*r.true_slip);
    if (r.condition == "vor") {
      o["gain"] = gain(r.gain);
      o["map_gain"] = gain(r.map_gain);
      if (r.true_gain) o["true_gain"] = gain(*r.true_gain);
    }
    j["trials"].push_back(o);
  }
  return j;
}

}  // namespace owlcal::evaluation
