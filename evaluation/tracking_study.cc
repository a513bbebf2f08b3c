#include "evaluation/tracking_study.h"

#include "io/json_strict.h"
#include "models/head_kinematics.h"

namespace owlcal::evaluation {

const TrackerSummary* TrackingStudy::Find(const std::string& tracker, int eye) const {
  for (const TrackerSummary& t : summaries)
    if (t.tracker == tracker && t.eye == eye) return &t;
  return nullptr;
}

nlohmann::json TrackingStudyJson(const TrackingStudy& s) {
  nlohmann::json j;
  j["source"] = s.source;
  j["has_truth"] = s.has_truth;
  j["off_target_px"] = kOffTargetPx;
  for (const TrackerSummary& t : s.summaries) {
    nlohmann::json r = {{"tracker", t.tracker},
                        {"eye", models::kEyeNames[t.eye]},
                        {"frames", t.num_frames},
                        {"found", t.num_found},
                        {"lost", t.num_lost},
                        {"reacquired", t.num_reacquired},
                        {"in_view", t.num_in_view},
                        {"lost_in_view", t.num_lost_in_view},
                        {"found_out_of_view", t.num_found_out_of_view},
                        {"error_frames", t.num_errors},
                        {"off_target", t.num_off_target},
                        {"rms_px", io::JsonNumber(t.rms_px)},
                        {"max_px", io::JsonNumber(t.max_px)},
                        {"lost_reasons", t.lost_reasons}};
    j["trackers"].push_back(r);
  }
  for (const SalienceRow& c : s.salience)
    j["salience"].push_back({{"rank", c.rank},
                             {"x_px", c.x_px},
                             {"y_px", c.y_px},
                             {"score", c.score},
                             {"object", c.object},
                             {"object_distance_px", io::JsonNumber(c.object_distance_px)},
                             {"fix_status", c.fix_status},
                             {"fix_reason", c.fix_reason},
                             {"fixated_object", c.fixated_object}});
  j["salience_on_object"] = s.num_on_object;
  j["salience_candidates"] = int(s.salience.size());
  j["salience_fixated"] = s.num_fixated;
  j["notes"] = s.notes;
  return j;
}

}  // namespace owlcal::evaluation
