// The tables of the result's diagnostics (MakeTables, reports/report.h): the lens model and board
// bow choices, the reference checks (latency, alignment, field of view), what the tag sheets add to
// the head fit, and the comparison with a reference calibration.
#include <cmath>
#include <string>
#include <vector>

#include "reports/report_tables.h"

namespace owlcal::reports::internal {
namespace {

// The number `k` of `j` with `sig` significant digits; empty when it is missing or not a number.
std::string CheckNum(const nlohmann::json& j, const char* k, int sig) {
  return j.contains(k) && j[k].is_number() ? Fmt(j[k].get<double>(), sig) : std::string();
}

// The "notes" list of `j` joined with "; ".
std::string CheckNotes(const nlohmann::json& j) {
  std::string n;
  for (const auto& x : j.value("notes", nlohmann::json::array())) n += (n.empty() ? "" : "; ") + x.get<std::string>();
  return n;
}

// latency_check: command to the first frame that shows the motion, per servo.
void AppendLatencyCheckTable(const nlohmann::json& rc, std::vector<Table>* out) {
  const nlohmann::json& l = rc["latency"];
  const bool truth = l.contains("stream_latency_truth_ms") && l["stream_latency_truth_ms"].is_number();
  Table t{"latency_check",
          "Latency: command to the first received frame that shows the motion, mean and \u03c3 (spread over the "
          "trials)" +
              std::string(truth ? "; truth: the reading the virtual Owl's stream latency (" +
                                      CheckNum(l, "stream_latency_truth_ms", 4) +
                                      " ms exposure to receipt), frame timing and servo slew and lag predict "
                                      "for each trial"
                                : "") +
              (CheckNotes(l).empty() ? "" : ". " + CheckNotes(l)),
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
        CheckNum(g, "mean_ms", 4),
        CheckNum(g, "sigma_ms", 2),
        CheckNum(g, "median_ms", 4),
        CheckNum(g, "min_ms", 4) + "\u2013" + CheckNum(g, "max_ms", 4)};
    if (truth)
      r.insert(
          r.end(),
          {CheckNum(g, "truth_mean_ms", 4),
           CheckNum(g, "error_ms", 2),
           std::to_string(g.value("num_on_predicted_frame", 0)) + " of " + std::to_string(g.value("num_with_truth", 0)),
           CheckNum(g, "max_abs_trial_error_ms", 2),
           CheckNum(l, "stream_latency_truth_ms", 4)});
    t.rows.push_back(r);
  }
  out->push_back(t);
}

// alignment_check: the cameras' alignment at the centre pose.
void AppendAlignmentCheckTable(const nlohmann::json& rc, std::vector<Table>* out) {
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
                    CheckNum(a, "roll_deg", 3),
                    CheckNum(a, "roll_sigma_deg", 2),
                    "\u00b1" + CheckNum(a, "tolerance_roll_deg", 3),
                    within("roll_deg", "tolerance_roll_deg"),
                    "deg"});
  t.rows.push_back({"vertical offset",
                    CheckNum(a, "vertical_offset_px", 3),
                    CheckNum(a, "vertical_offset_sigma_px", 2),
                    "\u00b1" + CheckNum(a, "tolerance_vertical_px", 3),
                    within("vertical_offset_px", "tolerance_vertical_px"),
                    "px"});
  t.rows.push_back({"horizontal offset", CheckNum(a, "horizontal_offset_px", 4), "", "", "", "px"});
  t.rows.push_back({"verdict", a.value("verdict", std::string()), "", "", "", advice});
  out->push_back(t);
}

// field_of_view: field of view and focal length against the datasheet.
void AppendFieldOfViewTable(const nlohmann::json& rc, std::vector<Table>* out) {
  const nlohmann::json& f = rc["field_of_view"];
  const auto rows = f.value("rows", nlohmann::json::array());
  bool truth = false;
  for (const auto& r : rows) truth |= r.contains("truth_fx_px") && r["truth_fx_px"].is_number();
  Table t{"field_of_view",
          "Field of view (through the image edges, lens model included) and focal length against the datasheet (" +
              f.value("source", std::string()) + "). " + CheckNotes(f),
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
                                        CheckNum(r, v, sig),
                                        CheckNum(r, sigma, 2),
                                        CheckNum(r, ref, ref_sig),
                                        "",
                                        "",
                                        pinhole ? CheckNum(r, pinhole, 4) : std::string()};
      if (r.contains(v) && r[v].is_number() && r.contains(ref) && r[ref].is_number()) {
        const double x = r[v].get<double>(), y = r[ref].get<double>();
        cells[5] = Fmt(x - y, 3);
        cells[6] = Fmt(100 * (x - y) / y, 3);
      }
      if (truth) cells.push_back(CheckNum(r, truth_key, sig));
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
  out->push_back(t);
}

}  // namespace

void AppendLensModelTable(const ReportData& d, std::vector<Table>* out) {
  if (!d.result.diagnostics.contains("lens_model_choice")) return;
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
  out->push_back(t);
}

void AppendReferenceCheckTables(const ReportData& d, std::vector<Table>* out) {
  if (!d.result.diagnostics.contains("reference_checks")) return;
  // Measured numbers against their references (evaluation/reference_checks.h).
  const nlohmann::json& rc = d.result.diagnostics["reference_checks"];
  if (rc.contains("latency")) AppendLatencyCheckTable(rc, out);
  if (rc.contains("alignment")) AppendAlignmentCheckTable(rc, out);
  if (rc.contains("field_of_view")) AppendFieldOfViewTable(rc, out);
}

void AppendTagTables(const ReportData& d, std::vector<Table>* out) {
  if (!d.result.diagnostics.contains("tags")) return;
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
  if (!c.rows.empty()) out->push_back(c);
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
  if (!e.rows.empty()) out->push_back(e);
}

void AppendBoardWarpTable(const ReportData& d, std::vector<Table>* out) {
  if (!d.result.diagnostics.contains("board_warp_choice")) return;
  // Flat or bowed board by cross-validation (fitting/lens_model_choice.h ChooseStereoBoardWarp).
  const nlohmann::json& w = d.result.diagnostics["board_warp_choice"];
  auto num = [](const nlohmann::json& j, const char* k, int sig) {
    return j.contains(k) && j[k].is_number() ? Fmt(j[k].get<double>(), sig) : std::string();
  };
  Table t{"board_warp",
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
  if (!t.rows.empty()) out->push_back(t);
}

void AppendReferenceComparisonTable(const ReportData& d, std::vector<Table>* out) {
  if (!d.result.diagnostics.contains("reference_comparison")) return;
  // Against a reference calibration of the same images (evaluation/reference_comparison.h).
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
    const bool sig = r.contains("owlcal_sigma") && r["owlcal_sigma"].is_number() && r["owlcal_sigma"].get<double>() > 0;
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
  out->push_back(t);
}

}  // namespace owlcal::reports::internal
