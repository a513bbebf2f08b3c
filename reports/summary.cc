#include "reports/summary.h"

#include <algorithm>
#include <cmath>

#include "evaluation/truth_compare.h"
#include "fitting/format.h"
#include "fitting/projection_uncertainty.h"
#include "models/head_kinematics.h"
#include "models/statistics.h"
#include "reports/camera_figures.h"
#include "reports/table.h"

namespace owlcal::reports {
namespace {

std::string PlusMinus(const fitting::Parameter& p) {
  if (p.held) return FmtWithSigma(p.value, NAN) + " (held)";
  if (!p.determined || !std::isfinite(p.sigma)) return FmtWithSigma(p.value, NAN) + " (not determined)";
  return FmtWithSigma(p.value, p.sigma) + " \u00b1 " + Fmt(p.sigma, 2);
}

using models::Median;

}  // namespace

std::optional<fitting::ValidIntrinsicsRegion> ValidRegion(const ReportData& d, int e) {
  const fitting::CalibrationResult& r = d.result;
  std::vector<fitting::CornerResidual> res;
  double s2 = 0;
  for (const auto& p : d.residuals)
    if (p.eye == e) {
      res.push_back({p.x, p.y, p.dx, p.dy});
      s2 += p.dx * p.dx + p.dy * p.dy;
    }
  const models::CameraIntrinsics* cam = r.cameras[e] ? &*r.cameras[e] : (r.head ? &r.head->intrinsics[e] : nullptr);
  if (!cam || res.empty()) return std::nullopt;
  return fitting::ComputeValidIntrinsicsRegion(
      *cam, fitting::IntrinsicsCovariance(r, e), res, std::sqrt(s2 / (2.0 * res.size())));
}

namespace {

// Headline numbers: reprojection RMS, focal lengths, principal points, baseline, IPD, servo
// scales, ranging, the fastest stable gain, the truth comparison.
void AddHeadlines(const ReportData& d, Summary* out) {
  Summary& s = *out;
  const fitting::CalibrationResult& r = d.result;
  const nlohmann::json& diag = r.diagnostics;
  auto add = [&](const std::string& q, const std::string& name, const std::string& note = "") {
    if (const fitting::Parameter* p = r.Find(name))
      s.headlines.push_back({q, PlusMinus(*p), DisplayUnit(p->unit), note});
  };
  if (diag.contains("stereo") && diag["stereo"].contains("rms_px")) {
    const auto& rms = diag["stereo"]["rms_px"];
    s.headlines.push_back({"reprojection RMS, left / right",
                           Fmt(rms.value("left", NAN), 3) + " / " + Fmt(rms.value("right", NAN), 3),
                           "px",
                           "per corner, joint stereo fit"});
  }
  for (const char* eye : {"left", "right"}) {
    add(std::string(eye) + " focal length fx", std::string(eye) + ".fx");
    add(std::string(eye) + " principal point cx", std::string(eye) + ".cx");
  }
  // Where each lens model is trusted (mrcal's valid-intrinsics region); a set verdict states its own.
  if (!(r.verdict.is_object() && r.verdict.contains("metrics"))) {
    const auto left = ValidRegion(d, 0), right = ValidRegion(d, 1);
    if (left && right)
      s.headlines.push_back({"lens model trusted over, left / right (valid-intrinsics region)",
                             Fmt(100 * left->valid_fraction, 3) + " / " + Fmt(100 * right->valid_fraction, 3),
                             "% of the image",
                             "projection uncertainty below the corner noise, and the residuals unbiased, where "
                             "corners were seen"});
  }
  add("stereo baseline", "stereo.baseline_mm");
  add("inter-pupillary distance (head fit)", "head.ipd_mm");
  {
    std::string scales;
    int fitted = 0;
    for (int k = 0; k < models::kNumServos; ++k) {
      const fitting::Parameter* p = r.Find(std::string("servo.") + models::kServoNames[k] + ".deg_per_us");
      if (!p || !p->determined) continue;
      ++fitted;
      scales += (scales.empty() ? "" : ", ") + std::string(models::kServoNames[k]) + " " + PlusMinus(*p);
    }
    if (fitted)
      s.headlines.push_back({"servo scales (" + std::to_string(fitted) + " maps fitted)", scales, "deg/\u00b5s", ""});
  }
  // The pan zero (fitting/head_gauge.h item 2): the one offset both pan maps share, which limits
  // their absolute angles however well the rest of each map is known.
  if (diag.contains("head") && diag["head"].contains("pan_zero") &&
      diag["head"]["pan_zero"].value("sigma_deg", NAN) > 0)
    s.headlines.push_back({"pan zero (both pan maps' common offset), 1\u03c3",
                           "\u00b1 " + Fmt(diag["head"]["pan_zero"]["sigma_deg"].get<double>(), 2),
                           "deg",
                           "where the optical axes are square to the eye baseline, found from the eye centres' "
                           "depths: it shifts both pan maps alike and cancels in vergence ranging"});
  if (d.ranging) {
    std::vector<double> e;
    int failed = 0;
    for (const auto& x : d.ranging->rows) {
      if (x.ok)
        e.push_back(100 * std::abs(x.rel_error));
      else
        ++failed;
    }
    s.headlines.push_back({"vergence range error, median |error|",
                           Fmt(Median(e), 3),
                           "%",
                           std::to_string(e.size()) + " fixations ranged, " + std::to_string(failed) + " failed"});
  }
  if (d.gains && d.gains->fastest)
    s.headlines.push_back({"fastest stable P gain (model, d = " + std::to_string(d.gains->delay_frames) + " frames)",
                           Fmt(d.gains->fastest->gain, 3),
                           "",
                           "2 % settling " + Fmt(d.gains->fastest->settling_time_s, 3) + " s"});
  if (std::any_of(r.parameters.begin(), r.parameters.end(), [](const auto& p) { return p.truth.has_value(); })) {
    const evaluation::TruthComparison c = evaluation::CompareWithTruth(r);
    s.headlines.push_back(
        {"virtual Owl: parameters within \u00b12\u03c3 of the truth",
         Fmt(100 * c.fraction_within_2sigma, 3),
         "%",
         std::to_string(c.num_with_sigma) + " compared, worst " + c.worst + " (z = " + Fmt(c.worst_z, 3) + ")"});
  }
}

// The bring-up (pipeline/bring_up.h): what the robot file got wrong, which the run corrected.
void AddBringUp(const ReportData& d, Summary* out) {
  Summary& s = *out;
  const nlohmann::json& diag = d.result.diagnostics;
  if (diag.contains("bring_up") && diag["bring_up"].is_object()) {
    const nlohmann::json& b = diag["bring_up"];
    const size_t n = b.value("findings", nlohmann::json::array()).size();
    s.headlines.push_back(
        {"bring-up: differences from your robot file, applied to the run",
         std::to_string(n),
         "",
         Fmt(b.value("robot_time_s", 0.0), 3) + " s of robot time (the limits protocol); " +
             (n ? "robot_corrected.yaml is your robot file as measured" : "the robot file agrees with the robot")});
    if (n)
      s.next_steps.push_back(
          "Compare robot_corrected.yaml (your robot file as measured: limits, directions, fitted "
          "centres, scales and IPD) with yours: the run used " +
          std::to_string(n) + " differences it measured (they lead the warnings).");
  }
}

// The person's work (pipeline/calibrate_work.h): placements and robot time, counted from the
// datasets, beside what the protocols planned.
void AddPersonWork(const ReportData& d, Summary* out) {
  const nlohmann::json& diag = d.result.diagnostics;
  if (!diag.contains("person_work") || !diag["person_work"].contains("counted_total")) return;
  const nlohmann::json& c = diag["person_work"]["counted_total"];
  const nlohmann::json p = diag["person_work"].value("planned_total", nlohmann::json::object());
  out->headlines.push_back(
      {"the person's work: target placements; the robot's time",
       std::to_string(c.value("placements", 0)) + " placements; " + Fmt(c.value("robot_time_s", 0.0) / 60, 3) + " min",
       "",
       "counted from the datasets (planned: " + std::to_string(p.value("placements", 0)) + " placements, " +
           Fmt(p.value("robot_time_s", 0.0) / 60, 3) + " min of open-loop steps + " +
           std::to_string(p.value("closed_loop_steps", 0)) + " closed-loop steps); per protocol: table person_work"});
}

// What the verdict found that the next steps depend on.
struct SummaryVerdict {
  int undetermined = 0;  // parameters not determined (gauges excepted)
  bool has_set_verdict = false;
  bool poor = false;  // the set verdict is not "good"
};

// Verdict: one a fit wrote (diagnostics.verdict: a string, or {status, reasons}), else from
// the solver summaries, undetermined parameters and warnings.
// The warnings shown: the first six and how many more.
SummaryVerdict JudgeSummary(const ReportData& d, Summary* out) {
  Summary& s = *out;
  const fitting::CalibrationResult& r = d.result;
  const nlohmann::json& diag = r.diagnostics;
  int undetermined = 0;
  // A parameter fixed by a gauge (the note says so) is a convention, not a gap in the data.
  for (const auto& p : r.parameters)
    undetermined += !p.determined && !p.held && p.note.find("gauge") == std::string::npos;
  bool failed = r.summaries.empty() && !r.cameras[0] && !r.cameras[1];
  for (const auto& sum : r.summaries)
    if (!sum.usable && sum.problem.find("initialisation") == std::string::npos) {
      failed = true;
      s.reasons.push_back("the " + sum.problem + " fit is not usable: " + sum.message);
    }
  // The set verdict (evaluation/set_verdict.h) is results.json's top-level `verdict`.
  const nlohmann::json& set_verdict = r.verdict;
  const bool has_set_verdict = set_verdict.is_object() && set_verdict.contains("status");
  const bool poor = has_set_verdict && set_verdict.at("status") != "good";
  if (has_set_verdict) {
    const std::string status = set_verdict.at("status").get<std::string>();
    s.verdict = "Calibration set: " + status;
    if (set_verdict.contains("reasons"))
      for (const auto& x : set_verdict.at("reasons")) s.reasons.push_back(x.get<std::string>());
    s.level = status == "good" ? "ok" : (status == "poor" ? "warn" : "bad");
    if (failed) {
      s.verdict += "; a fit failed";
      s.level = "bad";
    }
  } else if (diag.contains("verdict")) {
    const auto& v = diag["verdict"];
    if (v.is_string()) {
      s.verdict = v.get<std::string>();
    } else {
      s.verdict = v.value("status", std::string("see the reasons"));
      if (v.contains("reasons"))
        for (const auto& x : v["reasons"]) s.reasons.push_back(x.is_string() ? x.get<std::string>() : x.dump());
    }
    const std::string low = [&] {
      std::string t = s.verdict;
      for (auto& ch : t) ch = char(std::tolower(static_cast<unsigned char>(ch)));
      return t;
    }();
    s.level = low.find("fail") != std::string::npos || low.find("not usable") != std::string::npos ? "bad"
              : low.find("ok") == 0 || low.find("pass") == 0 || low.find("usable") == 0            ? "ok"
                                                                                                   : "warn";
  } else if (failed) {
    s.verdict = "Not usable: a fit failed";
    s.level = "bad";
  } else if (poor || undetermined > 0) {
    s.verdict = "Usable with care: " + std::to_string(undetermined) + " parameters could not be determined";
    s.level = "warn";
  } else {
    s.verdict = r.warnings.empty() ? "Usable: every fit converged and every parameter was determined"
                                   : "Usable, with " + std::to_string(r.warnings.size()) + " warnings to read";
    s.level = r.warnings.empty() ? "ok" : "warn";
  }
  if (!r.notes.empty())
    s.verdict += " (" + std::to_string(r.notes.size()) + (r.notes.size() == 1 ? " note" : " notes") +
                 " in the Discussion: what was dropped, nothing to do)";
  for (size_t i = 0; i < r.warnings.size() && i < 6; ++i) s.warnings.push_back(r.warnings[i]);
  if (r.warnings.size() > 6)
    s.warnings.push_back(std::to_string(r.warnings.size() - 6) + " more in the Discussion section");
  return {undetermined, has_set_verdict, poor};
}

// What to do next.
void AddNextSteps(const ReportData& d, const SummaryVerdict& verdict, Summary* out) {
  Summary& s = *out;
  const fitting::CalibrationResult& r = d.result;
  const nlohmann::json& set_verdict = r.verdict;
  const int undetermined = verdict.undetermined;
  const bool has_set_verdict = verdict.has_set_verdict;
  const bool poor = verdict.poor;
  const auto worst = WorstViews(d, 5);
  if (!worst.empty()) {
    std::string names;
    for (const auto& w : worst)
      names += (names.empty() ? "" : ", ") + std::string(models::kEyeNames[w.view.eye]) + " eye " + w.view.name;
    s.next_steps.push_back("Look at the worst calibration views (" + names +
                           "): retake or drop any with a blurred, moved or partly hidden board.");
  }
  if (has_set_verdict && set_verdict.contains("advice"))
    for (const auto& v : set_verdict.at("advice")) s.next_steps.push_back("Image set: " + v.get<std::string>() + ".");
  if (undetermined > 0 && !poor)
    s.next_steps.push_back(
        "Add views that determine the " + std::to_string(undetermined) +
        " undetermined parameters (listed in the Discussion): boards tilted by 30\u201345\u00b0, near "
        "the image corners and at several distances.");
  for (int e = 0; e < 2; ++e) {
    // With a set verdict, its trusted region is the one figure (evaluation/set_verdict.h): the same
    // numbers the verdict judged, so the summary never contradicts it.
    const nlohmann::json* tr = nullptr;
    if (has_set_verdict && set_verdict.contains("metrics") && set_verdict.at("metrics").contains("eyes")) {
      const nlohmann::json& eyes = set_verdict.at("metrics").at("eyes");
      if (eyes.contains(models::kEyeNames[e]) && eyes.at(models::kEyeNames[e]).contains("trusted_region") &&
          eyes.at(models::kEyeNames[e]).at("trusted_region").contains("fraction"))
        tr = &eyes.at(models::kEyeNames[e]).at("trusted_region");
    }
    if (tr) {
      const double frac = tr->value("fraction", 0.0), work = tr->value("working_fraction", 0.0);
      const double range = tr->value("range_m", 0.0);
      if (frac < 0.6)
        s.next_steps.push_back(
            std::string("The ") + models::kEyeNames[e] + " model is trusted over " +
            fitting::FixedOrDash(100 * work, 0) + " % of the working region and " +
            fitting::FixedOrDash(100 * frac, 0) +
            " % of the whole image (the set verdict's trusted region: projection uncertainty " +
            (range > 0 ? "at " + fitting::FixedOrDash(range, 2) + " m" : std::string("at infinity")) + " below " +
            fitting::FixedOrDash(tr->value("threshold_noise", 0.0), 1) + " \u00d7 the corner noise, " +
            fitting::FixedOrDash(tr->value("limit_px", 0.0), 2) +
            " px): to use the image edges, add views whose "
            "board reaches them.");
      continue;
    }
    const std::optional<fitting::ValidIntrinsicsRegion> v = ValidRegion(d, e);
    if (v && v->valid_fraction < 0.6)
      s.next_steps.push_back(std::string("The ") + models::kEyeNames[e] + " model is trusted over " +
                             Fmt(100 * v->valid_fraction, 2) +
                             " % of the image only (valid-intrinsics region): add "
                             "views whose board reaches the edges and corners.");
  }
  if (d.limits)
    for (const auto& l : d.limits->servos)
      if (l.recommended_min_us != l.configured_min_us || l.recommended_max_us != l.configured_max_us)
        s.next_steps.push_back("Update the robot file's " + l.name + " limits to " +
                               std::to_string(l.recommended_min_us) + "\u2013" + std::to_string(l.recommended_max_us) +
                               " \u00b5s (measured; configured " + std::to_string(l.configured_min_us) + "\u2013" +
                               std::to_string(l.configured_max_us) + ").");
  if (d.ranging) {
    int failed_r = 0;
    for (const auto& x : d.ranging->rows) failed_r += !x.ok;
    if (failed_r)
      s.next_steps.push_back("Repeat the " + std::to_string(failed_r) + " fixations that could not be ranged.");
  }
  if (s.level != "bad")
    s.next_steps.push_back(
        "Use calibration.yaml (OpenCV, metres) or intrinsics.xml/extrinsics.xml (the course's files, "
        "mm) in your programs; exports/ holds ROS, Kalibr and mrcal files" +
        std::string(r.head ? " and owl-pwm.h for the servo maps." : "."));
}

}  // namespace

Summary MakeSummary(const ReportData& d) {
  Summary s;
  AddHeadlines(d, &s);
  AddBringUp(d, &s);
  AddPersonWork(d, &s);
  const SummaryVerdict verdict = JudgeSummary(d, &s);
  AddNextSteps(d, verdict, &s);
  return s;
}

}  // namespace owlcal::reports
