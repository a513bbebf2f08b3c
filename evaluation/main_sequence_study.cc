#include "evaluation/main_sequence_study.h"

#include <cmath>

namespace owlcal::evaluation {

nlohmann::json MainSequenceStudyJson(const MainSequenceStudy& s) {
  nlohmann::json j;
  j["source"] = s.source;
  j["map"] = s.map;
  j["servo"] = s.servo;
  j["num_saccades"] = s.num_saccades;
  j["num_ok"] = s.num_ok;
  j["has_truth"] = s.has_truth;
  j["notes"] = s.notes;
  j["velocity_threshold_deg_per_s"] = s.fit.velocity_threshold_deg_per_s;
  auto motion = [](const fitting::PooledSaccadeMotion& m) {
    return nlohmann::json{{"ok", m.ok},
                          {"message", m.message},
                          {"slew_deg_per_s", m.slew_deg_per_s},
                          {"slew_sigma_deg_per_s", m.slew_sigma_deg_per_s},
                          {"fit_slew_sigma_deg_per_s", m.fit_slew_sigma_deg_per_s},
                          {"jackknife_slew_sigma_deg_per_s", m.jackknife_slew_sigma_deg_per_s},
                          {"scale_slew_sigma_deg_per_s", m.scale_slew_sigma_deg_per_s},
                          {"lag_s", m.lag_s},
                          {"lag_sigma_s", m.lag_sigma_s},
                          {"delay_s", m.delay_s},
                          {"delay_sigma_s", m.delay_sigma_s},
                          {"rms_deg", m.rms_deg},
                          {"frames", m.num_frames},
                          {"saccades", m.num_saccades}};
  };
  j["motion"] = motion(s.fit.motion);
  j["main_sequence"] = {{"ok", s.fit.peak.ok},
                        {"message", s.fit.peak.message},
                        {"vmax_deg_per_s", s.fit.peak.vmax_deg_per_s},
                        {"vmax_sigma_deg_per_s", s.fit.peak.vmax_sigma_deg_per_s},
                        {"c_deg", s.fit.peak.c_deg},
                        {"c_sigma_deg", s.fit.peak.c_sigma_deg},
                        {"lag_s", s.fit.peak.lag_s},
                        {"lag_sigma_s", s.fit.peak.lag_sigma_s},
                        {"rms_deg_per_s", s.fit.peak.rms_deg_per_s}};
  j["duration"] = {{"ok", s.fit.duration.ok},
                   {"message", s.fit.duration.message},
                   {"slew_deg_per_s", s.fit.duration.slew_deg_per_s},
                   {"slew_sigma_deg_per_s", s.fit.duration.slew_sigma_deg_per_s},
                   {"lag_s", s.fit.duration.lag_s},
                   {"lag_sigma_s", s.fit.duration.lag_sigma_s},
                   {"rms_s", s.fit.duration.rms_s}};
  if (s.has_truth) {
    j["truth"] = {{"slew_deg_per_s", s.true_slew_deg_per_s}, {"lag_s", s.true_lag_s}};
    j["truth_angles_motion"] = motion(s.truth_fit.motion);
  }
  j["saccades"] = nlohmann::json::array();
  for (const MainSequenceSaccade& sa : s.saccades) {
    nlohmann::json o = {{"saccade", sa.saccade},
                        {"amplitude_cmd_deg", sa.amplitude_cmd_deg},
                        {"repeat", sa.repeat},
                        {"direction", sa.direction},
                        {"status", sa.status},
                        {"reason", sa.reason}};
    if (sa.m.ok) {
      o["amplitude_deg"] = sa.m.amplitude_deg;
      o["amplitude_sigma_deg"] = sa.m.amplitude_sigma_deg;
      o["peak_deg_per_s"] = sa.m.peak_deg_per_s;
      o["peak_sigma_deg_per_s"] = sa.m.peak_sigma_deg_per_s;
      if (std::isfinite(sa.m.duration_s)) {
        o["duration_s"] = sa.m.duration_s;
        o["duration_sigma_s"] = sa.m.duration_sigma_s;
      }
    }
    if (std::isfinite(sa.true_peak_deg_per_s)) o["true_peak_deg_per_s"] = sa.true_peak_deg_per_s;
    j["saccades"].push_back(o);
  }
  return j;
}

}  // namespace owlcal::evaluation
