#include "evaluation/saccade_eval.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "fitting/ploop_analysis.h"
#include "models/statistics.h"
#include "models/units.h"

namespace owlcal::evaluation {
namespace {

using models::Median;

}  // namespace

SaccadeEvaluation EvaluateSaccades(const std::vector<fitting::StepTrace>& traces,
                                   double amplitude_deg,
                                   double slew_deg_per_s,
                                   double exposure_delay_s,
                                   double fps,
                                   double ploop_gain) {
  SaccadeEvaluation ev;
  ev.amplitude_deg = amplitude_deg;
  ev.slew_deg_per_s = slew_deg_per_s;
  ev.exposure_delay_s = exposure_delay_s;
  ev.fps = fps;
  ev.ploop_gain = ploop_gain;
  ev.bound_s = slew_deg_per_s > 0 && fps > 0
                   ? fitting::PhysicalLowerBoundS(amplitude_deg, slew_deg_per_s, exposure_delay_s, fps)
                   : kNaN;
  std::vector<double> sac, pl;
  for (const fitting::StepTrace& s : traces) {
    if (std::abs(std::abs(s.amplitude_deg) - amplitude_deg) > 1e-6) continue;
    if (s.controller == "saccade") {
      ++ev.num_trials;
      if (s.status != calib::TrialStatus::kOk) {
        ev.notes.push_back("saccade trial " + std::to_string(s.trial) + ": " + calib::TrialStatusName(s.status) +
                           (s.reason.empty() ? "" : ": " + s.reason));
        continue;
      }
      ++ev.num_ok;
      if (s.info.settled) {
        ++ev.num_settled;
        sac.push_back(s.info.settling_time);
      } else {
        ev.notes.push_back("saccade trial " + std::to_string(s.trial) + " did not settle within its frames");
      }
    } else if (s.controller == "p-loop" && std::abs(s.gain - ploop_gain) < 1e-9 &&
               s.status == calib::TrialStatus::kOk) {
      ++ev.ploop_trials;
      if (s.info.settled) {
        ++ev.ploop_settled;
        pl.push_back(s.info.settling_time);
      }
    }
  }
  ev.median_s = Median(sac);
  ev.lo_s = sac.empty() ? kNaN : *std::min_element(sac.begin(), sac.end());
  ev.hi_s = sac.empty() ? kNaN : *std::max_element(sac.begin(), sac.end());
  ev.ratio_to_bound = ev.median_s / ev.bound_s;
  ev.ploop_median_s = Median(pl);
  ev.speedup_vs_ploop = ev.ploop_median_s / ev.median_s;
  if (ev.ploop_trials == 0)
    ev.notes.push_back("no P-loop trial at gain " + std::to_string(ploop_gain) + " and " +
                       std::to_string(amplitude_deg) + " deg to compare with");
  return ev;
}

}  // namespace owlcal::evaluation
