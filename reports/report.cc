#include "reports/report.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "fitting/servo_map_eval.h"
#include "fitting/truth_compare.h"

namespace owlcal::reports {
namespace {

std::string Pct(double rel, int sig = 3) { return std::isfinite(rel) ? Fmt(100 * rel, sig) : ""; }
std::string Bool(bool b) { return b ? "yes" : "no"; }
// Where a loop-model number comes from (fitting/settling_model.h): nothing when fitted.
std::string Source(const std::string& source) {
  if (source == "prior") return " (a prior: the steps do not determine it)";
  return source == "fitted" || source.empty() ? "" : " (" + source + ")";
}

}  // namespace

double SteadyStateError(const StepTrace& s) {
  // 1 - the mean of the last 10 % of the trace (at least 3 samples): the part of the step not
  // done when the trial ended, whether or not it settled.
  if (s.y.size() < 3) return NAN;
  const size_t n = std::max<size_t>(3, s.y.size() / 10);
  double sum = 0;
  for (size_t k = s.y.size() - n; k < s.y.size(); ++k) sum += s.y[k];
  return 1.0 - sum / n;
}

std::vector<Table> MakeTables(const ReportData& d) {
  std::vector<Table> out;
  const bool any_truth = [&] {
    for (const auto& p : d.result.parameters)
      if (p.truth) return true;
    return false;
  }();
  {
    Table t{"parameters",
            "Fitted parameters with their standard deviation (1\u03c3)",
            {"name", "value", "\u03c3", "unit", "determined"},
            {}};
    if (any_truth) {
      t.header.push_back("truth");
      t.header.push_back("error");
      t.header.push_back("error / \u03c3");
    }
    for (const auto& p : d.result.parameters) {
      std::vector<std::string> r = {p.name,
                                    FmtWithSigma(p.value, p.sigma),
                                    p.determined ? Fmt(p.sigma, 2) : "",
                                    DisplayUnit(p.unit),
                                    p.held ? "held: " + p.note : (p.determined ? "yes" : "no: " + p.note)};
      if (any_truth) {
        if (p.truth) {
          r.push_back(Fmt(*p.truth, 6));
          r.push_back(Fmt(p.value - *p.truth, 3));
          r.push_back(p.determined && p.sigma > 0 ? Fmt((p.value - *p.truth) / p.sigma, 2) : "");
        } else {
          r.insert(r.end(), {"", "", ""});
        }
      }
      t.rows.push_back(r);
    }
    out.push_back(t);
  }
  if (d.result.diagnostics.contains("lens_model_choice")) {
    // The lens model choice by cross-validation (fitting/lens_model_choice.h).
    const nlohmann::json& l = d.result.diagnostics["lens_model_choice"];
    Table t{"lens_model",
            "Lens model: " + l.value("reason", std::string()),
            {"model",
             "chosen",
             "fit RMS [px]",
             "held-out RMS [px]",
             "held-out left [px]",
             "held-out right [px]",
             "held-out corners",
             "per fold [px]",
             "note"},
            {}};
    auto num = [](const nlohmann::json& j, const char* k) {
      return j.contains(k) && j[k].is_number() ? j[k].get<double>() : NAN;
    };
    for (const auto& c : l.value("candidates", nlohmann::json::array())) {
      std::string folds;
      for (const auto& f : c.value("fold_rms_px", nlohmann::json::array())) {
        if (!folds.empty()) folds += ' ';
        folds += Fmt(f.get<double>(), 3);
      }
      const std::string name = c.value("model", std::string());
      t.rows.push_back({name,
                        Bool(name == l.value("chosen", std::string())),
                        Fmt(num(c, "fit_rms_px"), 4),
                        Fmt(num(c, "heldout_rms_px"), 4),
                        Fmt(num(c, "heldout_rms_left_px"), 4),
                        Fmt(num(c, "heldout_rms_right_px"), 4),
                        std::to_string(c.value("num_heldout_corners", 0)),
                        folds,
                        c.value("message", std::string())});
    }
    if (t.rows.empty())
      t.rows.push_back({l.value("chosen", std::string()), "yes", "", "", "", "", "", "", "not cross-validated"});
    out.push_back(t);
  }
  if (d.result.diagnostics.contains("reference_checks")) {
    // Measured numbers against their references (fitting/reference_checks.h).
    const nlohmann::json& rc = d.result.diagnostics["reference_checks"];
    auto num = [](const nlohmann::json& j, const char* k, int sig) {
      return j.contains(k) && j[k].is_number() ? Fmt(j[k].get<double>(), sig) : std::string();
    };
    auto notes = [](const nlohmann::json& j) {
      std::string n;
      for (const auto& x : j.value("notes", nlohmann::json::array()))
        n += (n.empty() ? "" : "; ") + x.get<std::string>();
      return n;
    };
    if (rc.contains("latency")) {
      const nlohmann::json& l = rc["latency"];
      const bool truth = l.contains("stream_latency_truth_ms") && l["stream_latency_truth_ms"].is_number();
      Table t{"latency_check",
              "Latency: command to the first received frame that shows the motion, mean and \u03c3 (spread over the "
              "trials)" +
                  std::string(truth ? "; truth: the reading the virtual Owl's stream latency (" +
                                          num(l, "stream_latency_truth_ms", 4) +
                                          " ms exposure to receipt), frame timing and servo slew and lag predict "
                                          "for each trial"
                                    : "") +
                  (notes(l).empty() ? "" : ". " + notes(l)),
              {"servo", "trials ok of N", "mean [ms]", "\u03c3 [ms]", "median [ms]", "min\u2013max [ms]"},
              {}};
      if (truth)
        t.header.insert(t.header.end(),
                        {"truth [ms]",
                         "error [ms]",
                         "trials on the predicted frame",
                         "max |trial error| [ms]",
                         "stream latency truth [ms]"});
      for (const auto& g : l.value("groups", nlohmann::json::array())) {
        std::vector<std::string> r = {
            g.value("servo", std::string()),
            std::to_string(g.value("num_ok", 0)) + " of " + std::to_string(g.value("num_trials", 0)),
            num(g, "mean_ms", 4),
            num(g, "sigma_ms", 2),
            num(g, "median_ms", 4),
            num(g, "min_ms", 4) + "\u2013" + num(g, "max_ms", 4)};
        if (truth)
          r.insert(r.end(),
                   {num(g, "truth_mean_ms", 4),
                    num(g, "error_ms", 2),
                    std::to_string(g.value("num_on_predicted_frame", 0)) + " of " +
                        std::to_string(g.value("num_with_truth", 0)),
                    num(g, "max_abs_trial_error_ms", 2),
                    num(l, "stream_latency_truth_ms", 4)});
        t.rows.push_back(r);
      }
      out.push_back(t);
    }
    if (rc.contains("alignment")) {
      const nlohmann::json& a = rc["alignment"];
      std::string advice;
      for (const auto& x : a.value("advice", nlohmann::json::array()))
        advice += (advice.empty() ? "" : "; ") + x.get<std::string>();
      Table t{"alignment_check",
              "Camera alignment at the centre pose (left minus right, " + a.value("method", std::string()) + ", " +
                  std::to_string(a.value("num_frames", 0)) + " frames): " + a.value("verdict", std::string()) +
                  ". Tolerance: " + a.value("tolerance_source", std::string()),
              {"quantity", "value", "\u03c3 (spread)", "tolerance", "within", "unit"},
              {}};
      auto within = [&](const char* v, const char* tol) {
        if (!a.contains(v) || !a[v].is_number() || !a.contains(tol) || !a[tol].is_number()) return std::string();
        return Bool(std::abs(a[v].get<double>()) <= a[tol].get<double>());
      };
      t.rows.push_back({"roll",
                        num(a, "roll_deg", 3),
                        num(a, "roll_sigma_deg", 2),
                        "\u00b1" + num(a, "tolerance_roll_deg", 3),
                        within("roll_deg", "tolerance_roll_deg"),
                        "deg"});
      t.rows.push_back({"vertical offset",
                        num(a, "vertical_offset_px", 3),
                        num(a, "vertical_offset_sigma_px", 2),
                        "\u00b1" + num(a, "tolerance_vertical_px", 3),
                        within("vertical_offset_px", "tolerance_vertical_px"),
                        "px"});
      t.rows.push_back({"horizontal offset", num(a, "horizontal_offset_px", 4), "", "", "", "px"});
      t.rows.push_back({"verdict", a.value("verdict", std::string()), "", "", "", advice});
      out.push_back(t);
    }
    if (rc.contains("field_of_view")) {
      const nlohmann::json& f = rc["field_of_view"];
      const auto rows = f.value("rows", nlohmann::json::array());
      bool truth = false;
      for (const auto& r : rows) truth |= r.contains("truth_fx_px") && r["truth_fx_px"].is_number();
      Table t{"field_of_view",
              "Field of view (through the image edges, lens model included) and focal length against the datasheet (" +
                  f.value("source", std::string()) + "). " + notes(f),
              {"eye",
               "quantity",
               "fitted",
               "\u03c3",
               "datasheet",
               "fitted \u2212 datasheet",
               "difference [%]",
               "pinhole (from f)"},
              {}};
      if (truth) t.header.push_back("truth");
      for (const auto& r : rows) {
        const std::string eye = r.value("eye", std::string());
        // One row per quantity: value, sigma, datasheet, difference (absolute and %), pinhole, truth.
        auto row = [&](const char* label,
                       const char* v,
                       const char* sigma,
                       const char* ref,
                       const char* pinhole,
                       const char* truth_key,
                       int sig,
                       int ref_sig) {
          std::vector<std::string> cells = {eye,
                                            label,
                                            num(r, v, sig),
                                            num(r, sigma, 2),
                                            num(r, ref, ref_sig),
                                            "",
                                            "",
                                            pinhole ? num(r, pinhole, 4) : std::string()};
          if (r.contains(v) && r[v].is_number() && r.contains(ref) && r[ref].is_number()) {
            const double x = r[v].get<double>(), y = r[ref].get<double>();
            cells[5] = Fmt(x - y, 3);
            cells[6] = Fmt(100 * (x - y) / y, 3);
          }
          if (truth) cells.push_back(num(r, truth_key, sig));
          return cells;
        };
        t.rows.push_back(
            row("focal length fx [px]", "fx_px", "fx_sigma_px", "datasheet_f_px", nullptr, "truth_fx_px", 5, 4));
        t.rows.push_back(row("horizontal FOV [deg]",
                             "hfov_deg",
                             "hfov_sigma_deg",
                             "datasheet_hfov_deg",
                             "pinhole_hfov_deg",
                             "truth_hfov_deg",
                             4,
                             3));
        t.rows.push_back(row("vertical FOV [deg]",
                             "vfov_deg",
                             "vfov_sigma_deg",
                             "datasheet_vfov_deg",
                             "pinhole_vfov_deg",
                             "truth_vfov_deg",
                             4,
                             3));
      }
      out.push_back(t);
    }
  }
  if (d.result.diagnostics.contains("tags")) {
    // What the tag sheets add to the head fit (pipeline/tag_study.h).
    const nlohmann::json& g = d.result.diagnostics["tags"];
    auto num = [](const nlohmann::json& j, const char* k, int sig) {
      return j.contains(k) && j[k].is_number() ? Fmt(j[k].get<double>(), sig) : std::string();
    };
    auto pair = [](const nlohmann::json& j, const char* k, int sig) {
      if (!j.contains(k) || !j[k].is_array() || j[k].size() != 2) return std::string();
      return Fmt(j[k][0].get<double>(), sig) + " / " + Fmt(j[k][1].get<double>(), sig);
    };
    Table c{"tag_coverage",
            "Head fit coverage per kind of target: views and corners (left / right), the whitening σ each kind's own "
            "residuals give (measured × the sigma factor), and the pulse widths at which each servo was seen",
            {"kind", "views", "corners", "whitening σ [px]", "measured σ [px]"},
            {}};
    for (int s = 0; s < models::kNumServos; ++s) c.header.push_back(std::string(models::kServoNames[s]) + " [µs]");
    const nlohmann::json classes = g.value("classes", nlohmann::json::object());
    for (const auto& [name, cls] : classes.items()) {
      std::vector<std::string> r = {name,
                                    pair(cls, "views", 4),
                                    pair(cls, "corners", 6),
                                    pair(cls, "whitening_sigma_px", 3),
                                    pair(cls, "measured_sigma_px", 3)};
      const nlohmann::json pwm = cls.value("pwm_us", nlohmann::json::object());
      for (int s = 0; s < models::kNumServos; ++s) {
        const char* n = models::kServoNames[s];
        r.push_back(pwm.contains(n) ? std::to_string(pwm[n][0].get<int>()) + "–" + std::to_string(pwm[n][1].get<int>())
                                    : std::string());
      }
      c.rows.push_back(r);
    }
    if (!c.rows.empty()) out.push_back(c);
    const nlohmann::json servo_ends = g.value("servo_ends", nlohmann::json::array());
    const bool truth = !servo_ends.empty() && servo_ends[0].contains("error_with_tags_deg") &&
                       servo_ends[0]["error_with_tags_deg"].is_number();
    Table e{
        "tag_servo_ends",
        "Servo maps at the ends of their configured range: σ of the angle with the tag sheets fused into the head "
        "fit and from the chessboard views alone (fit without the tags: " +
            g.value("without_tags_fit", std::string()) + "; the calibration's head result: " +
            g.value("head_result", std::string()) + ")" + (truth ? "; fitted minus true angle with both fits" : "") +
            (g.contains("floors") && g["floors"].is_string() ? ". " + g["floors"].get<std::string>() : std::string()) +
            (g.contains("note") && g["note"].is_string() ? ". NOTE: " + g["note"].get<std::string>() : std::string()),
        {"servo",
         "end",
         "pulse [µs]",
         g.contains("note") ? "σ with tags [deg] (diagnostic)" : "σ with tags [deg]",
         "σ without tags [deg]",
         "σ ratio"},
        {}};
    if (truth) e.header.insert(e.header.end(), {"error with tags [deg]", "error without tags [deg]"});
    for (const auto& x : servo_ends) {
      const bool both = x.contains("sigma_with_tags_deg") && x.contains("sigma_without_tags_deg") &&
                        x["sigma_with_tags_deg"].is_number() && x["sigma_without_tags_deg"].is_number() &&
                        x["sigma_with_tags_deg"].get<double>() > 0;
      std::vector<std::string> r = {
          x.value("servo", std::string()),
          x.value("end", std::string()),
          num(x, "pwm_us", 4),
          num(x, "sigma_with_tags_deg", 3),
          num(x, "sigma_without_tags_deg", 3),
          both ? Fmt(x["sigma_without_tags_deg"].get<double>() / x["sigma_with_tags_deg"].get<double>(), 3)
               : std::string()};
      if (truth) r.insert(r.end(), {num(x, "error_with_tags_deg", 3), num(x, "error_without_tags_deg", 3)});
      e.rows.push_back(r);
    }
    if (!e.rows.empty()) out.push_back(e);
  }
  if (d.result.diagnostics.contains("board_warp_choice")) {
    // Flat or bowed board by cross-validation (fitting/lens_model_choice.h ChooseStereoBoardWarp).
    const nlohmann::json& w = d.result.diagnostics["board_warp_choice"];
    auto num = [](const nlohmann::json& j, const char* k, int sig) {
      return j.contains(k) && j[k].is_number() ? Fmt(j[k].get<double>(), sig) : std::string();
    };
    Table t{
        "board_warp",
        "Board: " + w.value("reason", std::string()),
        {"board", "chosen", "fit RMS [px]", "held-out RMS [px]", "held-out left [px]", "held-out right [px]", "note"},
        {}};
    for (const auto& c : w.value("candidates", nlohmann::json::array())) {
      const std::string name = c.value("board", std::string());
      t.rows.push_back({name,
                        Bool(name == w.value("chosen", std::string())),
                        num(c, "fit_rms_px", 4),
                        num(c, "heldout_rms_px", 4),
                        num(c, "heldout_rms_left_px", 4),
                        num(c, "heldout_rms_right_px", 4),
                        c.value("message", std::string())});
    }
    if (!t.rows.empty()) out.push_back(t);
  }
  if (d.result.diagnostics.contains("reference_comparison")) {
    // Against a reference calibration of the same images (fitting/reference_comparison.h).
    const nlohmann::json& rc = d.result.diagnostics["reference_comparison"];
    auto num = [](const nlohmann::json& j, const char* k, int sig) {
      return j.contains(k) && j[k].is_number() ? Fmt(j[k].get<double>(), sig) : std::string();
    };
    Table t{"reference_comparison",
            (rc.value("ok", false) ? std::string("Against the reference: ")
                                   : std::string("Not compared with the reference: ")) +
                rc.value("message", std::string()),
            {"parameter",
             "unit",
             "reference A",
             "owlcal C",
             "\u03c3",
             "C \u2212 A",
             "(C \u2212 A) / \u03c3",
             "detection (B \u2212 A)",
             "lens model (D \u2212 B)",
             "estimator (E \u2212 D)",
             "board bow (C \u2212 E)"},
            {}};
    for (const auto& r : rc.value("rows", nlohmann::json::array())) {
      const bool sig =
          r.contains("owlcal_sigma") && r["owlcal_sigma"].is_number() && r["owlcal_sigma"].get<double>() > 0;
      t.rows.push_back({r.value("name", std::string()),
                        r.value("unit", std::string()),
                        num(r, "reference", 6),
                        num(r, "owlcal", 6),
                        num(r, "owlcal_sigma", 2),
                        num(r, "total", 3),
                        sig ? Fmt(r["total"].get<double>() / r["owlcal_sigma"].get<double>(), 2) : std::string(),
                        num(r, "detection", 3),
                        num(r, "model", 3),
                        num(r, "estimator", 3),
                        num(r, "bow", 3)});
    }
    out.push_back(t);
  }
  if (!d.result.summaries.empty()) {
    Table t{"solver",
            "Solver summaries",
            {"problem", "termination", "iterations", "RMS [px]", "residuals", "outliers", "time [s]", "usable"},
            {}};
    for (const auto& s : d.result.summaries)
      t.rows.push_back({s.problem,
                        s.termination,
                        std::to_string(s.iterations),
                        Fmt(s.rms_px, 4),
                        std::to_string(s.num_residuals),
                        std::to_string(s.num_outliers),
                        Fmt(s.time_s, 3),
                        Bool(s.usable)});
    out.push_back(t);
  }
  {
    Table t{"undetermined",
            "Parameters the data could not determine, and warnings",
            {"parameter or warning", "reason"},
            {}};
    for (const auto& p : d.result.parameters)
      if (!p.determined && !p.held) t.rows.push_back({p.name, p.note});
    for (const auto& w : d.result.warnings) t.rows.push_back({"warning", w});
    out.push_back(t);
  }
  if (any_truth) {
    const fitting::TruthComparison c = fitting::CompareWithTruth(d.result);
    Table t{"truth_comparison",
            "Virtual Owl: fitted vs true values (" + std::to_string(c.num_with_sigma) + " with \u03c3, " +
                Pct(c.fraction_within_2sigma, 3) + " % within \u00b12\u03c3, RMS z = " + Fmt(c.rms_z, 3) + ")",
            {"name", "value", "truth", "error", "unit", "\u03c3", "error / \u03c3", "within \u00b12\u03c3"},
            {}};
    for (const auto& r : c.rows)
      t.rows.push_back({r.name,
                        Fmt(r.value, 7),
                        Fmt(r.truth, 7),
                        Fmt(r.error, 3),
                        DisplayUnit(r.unit),
                        Fmt(r.sigma, 2),
                        Fmt(r.z, 3),
                        std::isfinite(r.z) ? Bool(r.within_2sigma) : "n/a"});
    out.push_back(t);
  }
  if (d.truth && d.result.head) {
    // Whole maps, not just their parameters: fitted minus true angle over the configured range.
    Table t{"servo_map_truth",
            "Virtual Owl: fitted servo maps vs the truth over each servo's configured range",
            {"servo", "range [\u00b5s]", "RMS [deg]", "max |error| [deg]", "mean error [deg]"},
            {}};
    for (int s = 0; s < models::kNumServos; ++s) {
      const fitting::Parameter* p = d.result.Find("servo." + std::string(models::kServoNames[s]) + ".deg_per_us");
      if (!p || !p->determined) continue;
      const models::ServoConfig& c = d.config.servos[s];
      const fitting::ServoMapError e = fitting::ServoMapErrorOverRange(*d.result.head, *d.truth, s, c.min_us, c.max_us);
      t.rows.push_back({models::kServoNames[s],
                        std::to_string(c.min_us) + "\u2013" + std::to_string(c.max_us),
                        Fmt(e.rms_deg, 3),
                        Fmt(e.max_abs_deg, 3),
                        Fmt(e.mean_deg, 3)});
    }
    if (!t.rows.empty()) out.push_back(t);
  }
  if (d.ranging) {
    const auto& r = *d.ranging;
    Table t{"ranging",
            "Vergence ranging per fixation (every fixation the protocol tried; only status ok is ranged)",
            {"fixation",
             "status",
             "true [m]",
             "calibrated [m]",
             "error [%]",
             "\u00b12\u03c3 [%]",
             "within \u00b12\u03c3",
             "ray gap [mm]",
             "course nominal [m]",
             "nominal error [%]",
             "reason"},
            {}};
    for (const auto& x : r.rows)
      t.rows.push_back({std::to_string(x.index),
                        calib::TrialStatusName(x.status),
                        Fmt(x.true_m, 4),
                        x.ok ? Fmt(x.range_m, 5) : "not ranged",
                        x.ok ? Pct(x.rel_error) : "",
                        x.ok ? Pct(2 * x.sigma_m / x.true_m) : "",
                        x.ok ? Bool(std::abs(x.error_m) <= 2 * x.sigma_m) : "",
                        std::isfinite(x.gap_m) ? Fmt(1000 * x.gap_m, 3) : "",
                        x.ok ? (x.nominal_m ? Fmt(*x.nominal_m, 4) : "none: gaze rays diverge") : "",
                        x.ok && x.nominal_m ? Pct(x.nominal_rel_error) : "",
                        x.reason});
    out.push_back(t);
    // Robust summary: the median and the count of failures, not an RMS one outlier dominates.
    std::vector<double> cal, nom;
    int within = 0, nominal_none = 0;
    std::map<std::string, int> by_status;
    for (const auto& x : r.rows) {
      if (x.ok) {
        cal.push_back(std::abs(x.rel_error));
        within += std::abs(x.error_m) <= 2 * x.sigma_m;
        if (x.nominal_m)
          nom.push_back(std::abs(x.nominal_rel_error));
        else
          ++nominal_none;
      } else {
        ++by_status[calib::TrialStatusName(x.status)];
      }
    }
    auto median = [](std::vector<double> v) -> double {
      if (v.empty()) return NAN;
      std::sort(v.begin(), v.end());
      return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
    };
    auto maxv = [](const std::vector<double>& v) -> double {
      return v.empty() ? NAN : *std::max_element(v.begin(), v.end());
    };
    const std::string of_n = " of " + std::to_string(r.rows.size());
    Table s{
        "ranging_summary", "Vergence ranging summary", {"quantity", "calibrated head", "course nominal method"}, {}};
    s.rows = {{"fixations ok and ranged", std::to_string(cal.size()) + of_n, std::to_string(nom.size()) + of_n}};
    for (const auto& [status, n] : by_status)
      s.rows.push_back({"fixations " + status + " (not ranged; reasons in the table)", std::to_string(n) + of_n, ""});
    s.rows.push_back({"ok but no nominal range", "", std::to_string(nominal_none) + " (gaze rays diverge)"});
    s.rows.push_back({"median |relative error| [%]", Pct(median(cal)), Pct(median(nom))});
    s.rows.push_back({"max |relative error| [%]", Pct(maxv(cal)), Pct(maxv(nom))});
    s.rows.push_back(
        {"within \u00b12\u03c3 of the truth", std::to_string(within) + " of " + std::to_string(cal.size()), ""});
    // What was (not) checked: the size check's reference, sigma without a covariance (the notes
    // per fixation are the table's reasons).
    for (const auto& n : r.notes)
      if (n.rfind("fixation ", 0) != 0) s.rows.push_back({"note", n, ""});
    out.push_back(s);
  }
  if (!d.steps.empty()) {
    int measured = 0, ok = 0;
    for (const auto& s : d.steps)
      if (!s.simulated) {
        ++measured;
        ok += s.status == calib::TrialStatus::kOk;
      }
    Table t{
        "step_metrics",
        "Step-response metrics (MATLAB stepinfo with y_init = 0, y_final = 1 in fractions of the step); every trial "
        "the protocol tried: " +
            std::to_string(ok) + " ok of " + std::to_string(measured),
        {"gain",
         "step [deg]",
         "trial",
         "rise 10\u201390 % [s]",
         "settling 2 % [s]",
         "overshoot [%]",
         "undershoot [%]",
         "peak [-]",
         "peak time [s]",
         "steady-state error [%]",
         "residual offset [px]",
         "source",
         "status",
         "reason"},
        {}};
    for (const auto& s : d.steps) {
      const std::string source = s.simulated                ? "model"
                                 : s.controller == "p-loop" ? "measured"
                                                            : "measured, " + s.controller;
      if (s.t_s.empty()) {
        t.rows.push_back({Fmt(s.gain, 3),
                          Fmt(s.amplitude_deg, 3),
                          std::to_string(s.trial),
                          "",
                          "",
                          "",
                          "",
                          "",
                          "",
                          "",
                          "",
                          source,
                          calib::TrialStatusName(s.status),
                          s.reason});
        continue;
      }
      t.rows.push_back({Fmt(s.gain, 3),
                        Fmt(s.amplitude_deg, 3),
                        std::to_string(s.trial),
                        Fmt(s.info.rise_time, 3),
                        s.info.settled ? Fmt(s.info.settling_time, 3) : "not settled",
                        Fmt(s.info.overshoot_pct, 3),
                        Fmt(s.info.undershoot_pct, 3),
                        Fmt(s.info.peak, 4),
                        Fmt(s.info.peak_time, 3),
                        Pct(SteadyStateError(s), 3),
                        Fmt(s.residual_px, 3),
                        source,
                        calib::TrialStatusName(s.status),
                        s.reason});
    }
    out.push_back(t);
  }
  if (d.settling) {
    const auto& st = *d.settling;
    auto range = [](double med, double lo, double hi) {
      if (!std::isfinite(med)) return std::string("not settled");
      return Fmt(med, 3) + " (" + Fmt(lo, 3) + "\u2013" + Fmt(hi, 3) + ")";
    };
    int agree = 0;
    for (const auto& r : st.rows) agree += r.agreement.rfind("agrees", 0) == 0;
    Table t{"settling_model",
            "Settling: the loop model against the measured trials, per gain and step (" + std::to_string(agree) +
                " of " + std::to_string(st.rows.size()) + " agree). Loop model: slew " +
                Fmt(st.model.slew_us_per_s * st.deg_per_us, 4) + " \u00b0/s" + Source(st.slew_source) + ", lag " +
                Fmt(1000 * st.model.lag_s, 3) + " ms" + Source(st.lag_source) + ", exposure delay " +
                Fmt(1000 * st.model.exposure_delay_s, 3) + " ms (fitted from the step frames), latency " +
                Fmt(st.latency_ms, 4) + " ms, backlash " + Fmt(st.model.hysteresis_us, 3) + " \u00b5s; course model: " +
                "ideal P loop with d = " + std::to_string(st.ideal_delay_frames) + " frames",
            {"gain",
             "step [deg]",
             "band [%]",
             "trials run of N",
             "measured [s] median (min\u2013max)",
             "loop model [s] median (range)",
             "course model [s]",
             "agreement",
             "why"},
            {}};
    for (const auto& r : st.rows)
      t.rows.push_back(
          {Fmt(r.gain, 3),
           Fmt(r.amplitude_deg, 3),
           Fmt(100 * r.band, 3),
           std::to_string(r.num_ok) + " of " + std::to_string(r.num_trials),
           r.num_ok
               ? range(r.measured_median_s, r.measured_lo_s, r.measured_hi_s) +
                     (r.num_settled < r.num_ok ? ", " + std::to_string(r.num_ok - r.num_settled) + " not settled" : "")
               : "",
           range(r.predicted_median_s, r.predicted_lo_s, r.predicted_hi_s),
           r.ideal_stable ? (std::isfinite(r.ideal_s) ? Fmt(r.ideal_s, 3) : "not settled") : "unstable",
           r.agreement,
           r.why});
    out.push_back(t);
  }
  if (d.saccade) {
    // The calibrated-map saccade against the physical bound and the P loop.
    const auto& sa = *d.saccade;
    auto ms = [](double s) { return std::isfinite(s) ? Fmt(1000 * s, 4) : std::string("not settled"); };
    Table t{"saccade",
            "Calibrated saccade, " + Fmt(sa.amplitude_deg, 3) +
                " deg steps: one saccade from the calibrated servo maps "
                "and the target's pixel, then latency-aware corrections; 2 % settling against the physical bound (slew "
                "time + exposure-to-arrival latency + one frame) and the course's P loop at K = " +
                Fmt(sa.ploop_gain, 3) + " (same step). " + std::to_string(sa.num_ok) + " ok of " +
                std::to_string(sa.num_trials) + " trials",
            {"controller",
             "trials ok of N",
             "settled",
             "2 % settling [ms] median (min–max)",
             "bound [ms]",
             "ratio to bound",
             "speed-up vs P loop"},
            {}};
    t.rows.push_back(
        {"calibrated saccade",
         std::to_string(sa.num_ok) + " of " + std::to_string(sa.num_trials),
         std::to_string(sa.num_settled),
         std::isfinite(sa.median_s) ? ms(sa.median_s) + " (" + ms(sa.lo_s) + "–" + ms(sa.hi_s) + ")" : "not settled",
         ms(sa.bound_s),
         std::isfinite(sa.ratio_to_bound) ? Fmt(sa.ratio_to_bound, 3) : "",
         std::isfinite(sa.speedup_vs_ploop) ? Fmt(sa.speedup_vs_ploop, 3) : ""});
    t.rows.push_back({"P loop, K = " + Fmt(sa.ploop_gain, 3),
                      std::to_string(sa.ploop_trials) + " ok",
                      std::to_string(sa.ploop_settled),
                      ms(sa.ploop_median_s),
                      ms(sa.bound_s),
                      std::isfinite(sa.ploop_median_s / sa.bound_s) ? Fmt(sa.ploop_median_s / sa.bound_s, 3) : "",
                      "1"});
    for (const auto& n : sa.notes) t.rows.push_back({"note: " + n, "", "", "", "", "", ""});
    out.push_back(t);
  }
  if (d.gains) {
    const auto& g = *d.gains;
    Table t{"gain_study",
            "Incremental P loop with latency (model): gain limits and the fastest stable gain",
            {"quantity", "value"},
            {}};
    t.rows = {{"delay [frames]", std::to_string(g.delay_frames)},
              {"frame rate [fps]", Fmt(g.fps, 3)},
              {"K_crit = 2 sin(pi / (2 (2d + 1)))", Fmt(g.critical_gain, 4)},
              {"K_mono = d^d / (d + 1)^(d + 1)", Fmt(g.monotone_gain, 4)}};
    if (g.fastest) {
      t.rows.push_back({"fastest stable gain", Fmt(g.fastest->gain, 3)});
      t.rows.push_back({"its 2 % settling [frames]", std::to_string(g.fastest->settling_frames)});
      t.rows.push_back({"its 2 % settling [s]", Fmt(g.fastest->settling_time_s, 3)});
      t.rows.push_back({"its overshoot [%]", Fmt(g.fastest->overshoot_pct, 3)});
    }
    for (size_t i = 0; i < g.amplitudes_deg.size(); ++i)
      t.rows.push_back({"physical lower bound, " + Fmt(g.amplitudes_deg[i], 3) + " deg step [s]",
                        Fmt(g.lower_bound_fast_s[i], 3) + " - " + Fmt(g.lower_bound_slow_s[i], 3)});
    out.push_back(t);
  }
  if (d.limits) {
    Table t{"limits",
            "Servo limits: configured vs measured",
            {"servo",
             "configured min [\u00b5s]",
             "configured max [\u00b5s]",
             "measured min [\u00b5s]",
             "low end",
             "measured max [\u00b5s]",
             "high end",
             "measured range [deg]",
             "recommended min [\u00b5s]",
             "recommended max [\u00b5s]"},
            {}};
    for (const auto& s : d.limits->servos)
      t.rows.push_back({s.name,
                        std::to_string(s.configured_min_us),
                        std::to_string(s.configured_max_us),
                        s.measured_min_us ? Fmt(*s.measured_min_us, 6) : "",
                        s.measured_min_us ? fitting::LimitCauseName(s.min_cause) : "",
                        s.measured_max_us ? Fmt(*s.measured_max_us, 6) : "",
                        s.measured_max_us ? fitting::LimitCauseName(s.max_cause) : "",
                        std::isfinite(s.measured_max_deg - s.measured_min_deg)
                            ? Fmt(std::abs(s.measured_max_deg - s.measured_min_deg), 4)
                            : "",
                        std::to_string(s.recommended_min_us),
                        std::to_string(s.recommended_max_us)});
    out.push_back(t);
  }
  return out;
}

}  // namespace owlcal::reports
