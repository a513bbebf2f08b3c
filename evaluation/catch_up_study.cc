#include "evaluation/catch_up_study.h"

#include "evaluation/study_cells.h"
#include "io/json_strict.h"

namespace owlcal::evaluation {

nlohmann::json CatchUpStudyJson(const CatchUpStudy& s) {
  nlohmann::json j = TrialStudyHeaderJson(s);
  j["trials"] = nlohmann::json::array();
  for (const CatchUpTrial& t : s.trials)
    j["trials"].push_back({{"trial", t.trial},
                           {"speed_deg_per_s", t.speed_deg_per_s},
                           {"direction", t.direction},
                           {"status", t.status},
                           {"reason", t.reason},
                           {"frames", t.frames},
                           {"found", t.found},
                           {"saccades", t.saccades},
                           {"rms_error_deg", io::JsonNumber(t.rms_error_deg)},
                           {"true_rms_error_deg", io::JsonNumber(t.true_rms_error_deg)},
                           {"mean_error_before_deg", io::JsonNumber(t.mean_before_deg)},
                           {"mean_error_after_deg", io::JsonNumber(t.mean_after_deg)},
                           {"median_response_ms", io::JsonNumber(t.median_response_ms)}});
  j["saccades"] = nlohmann::json::array();
  for (const CatchUpSaccade& c : s.saccades)
    j["saccades"].push_back({{"trial", c.trial},
                             {"k", c.k},
                             {"t_s", c.t_s},
                             {"error_before_deg", io::JsonNumber(c.error_before_deg)},
                             {"error_after_deg", io::JsonNumber(c.error_after_deg)},
                             {"response_ms", io::JsonNumber(c.response_ms)}});
  return j;
}

}  // namespace owlcal::evaluation
