// The saccade evaluation: bound, medians over ok trials, failed trials named, P-loop speed-up.
#include "evaluation/saccade_eval.h"

#include <cmath>

#include <gtest/gtest.h>

#include "fitting/ploop_analysis.h"

namespace owlcal::evaluation {
namespace {

fitting::StepTrace Trace(const std::string& controller,
                         double gain,
                         double amp,
                         int trial,
                         double settle_s,
                         calib::TrialStatus status = calib::TrialStatus::kOk) {
  fitting::StepTrace s;
  s.controller = controller;
  s.gain = gain;
  s.amplitude_deg = amp;
  s.trial = trial;
  s.status = status;
  if (status != calib::TrialStatus::kOk) s.reason = "target left the image";
  s.info.settled = std::isfinite(settle_s);
  s.info.settling_time = settle_s;
  return s;
}

TEST(SaccadeEval, MediansRatioAndSpeedUpFromOkTrialsOnly) {
  std::vector<fitting::StepTrace> t = {
      Trace("saccade", 0, 10, 0, 0.20),
      Trace("saccade", 0, -10, 1, 0.24),
      Trace("saccade", 0, 10, 2, 0.22),
      Trace("saccade", 0, 10, 3, 0.1, calib::TrialStatus::kLostTarget),  // failed: named, not counted
      Trace("saccade", 0, 5, 4, 0.15),                                   // other amplitude: ignored
      Trace("p-loop", 0.1, 10, 0, 0.70),
      Trace("p-loop", 0.1, -10, 1, 0.90),
      Trace("p-loop", 0.2, 10, 2, 0.30),  // other gain: ignored
  };
  const SaccadeEvaluation ev = EvaluateSaccades(t, 10, 400, 0.1, 30);
  EXPECT_NEAR(ev.bound_s, fitting::PhysicalLowerBoundS(10, 400, 0.1, 30), 1e-12);
  EXPECT_NEAR(ev.bound_s, 10.0 / 400 + 0.1 + 1.0 / 30, 1e-9);
  EXPECT_EQ(ev.num_trials, 4);
  EXPECT_EQ(ev.num_ok, 3);
  EXPECT_EQ(ev.num_settled, 3);
  EXPECT_NEAR(ev.median_s, 0.22, 1e-12);
  EXPECT_NEAR(ev.lo_s, 0.20, 1e-12);
  EXPECT_NEAR(ev.hi_s, 0.24, 1e-12);
  EXPECT_NEAR(ev.ratio_to_bound, 0.22 / ev.bound_s, 1e-12);
  EXPECT_EQ(ev.ploop_trials, 2);
  EXPECT_NEAR(ev.ploop_median_s, 0.80, 1e-12);
  EXPECT_NEAR(ev.speedup_vs_ploop, 0.80 / 0.22, 1e-12);
  ASSERT_EQ(ev.notes.size(), 1u);
  EXPECT_NE(ev.notes[0].find("saccade trial 3: lost target"), std::string::npos) << ev.notes[0];
}

TEST(SaccadeEval, NothingSettledIsNaNAndSaysSo) {
  std::vector<fitting::StepTrace> t = {Trace("saccade", 0, 10, 0, NAN)};
  const SaccadeEvaluation ev = EvaluateSaccades(t, 10, 400, 0.1, 30);
  EXPECT_EQ(ev.num_ok, 1);
  EXPECT_EQ(ev.num_settled, 0);
  EXPECT_TRUE(std::isnan(ev.median_s));
  EXPECT_TRUE(std::isnan(ev.ratio_to_bound));
  EXPECT_EQ(ev.ploop_trials, 0);
  ASSERT_EQ(ev.notes.size(), 2u);  // did not settle; no P loop to compare with
  EXPECT_NE(ev.notes[0].find("did not settle"), std::string::npos);
  EXPECT_NE(ev.notes[1].find("no P-loop trial"), std::string::npos);
}

TEST(SaccadeEval, NoSlewMeansNoBound) {
  const SaccadeEvaluation ev = EvaluateSaccades({}, 10, 0, 0.1, 30);
  EXPECT_TRUE(std::isnan(ev.bound_s));
}

}  // namespace
}  // namespace owlcal::evaluation
