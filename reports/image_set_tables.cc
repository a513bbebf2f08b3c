#include "reports/image_set_tables.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "fitting/format.h"
#include "reports/table.h"
#include "reports/verdict_tables.h"

namespace owlcal::reports {

using evaluation::RangeMeasurement;
using fitting::FixedOrDash;

namespace {

// What choosing the bow does to the lens: the held-out gain with its standard error, and the
// bowed fit's fx, k1, k2, k3 per eye against the flat fit's, in the flat fit's sigma.
std::string BowEffectMarkdown(const fitting::BoardWarpChoice& w) {
  if (w.scores.size() != 2 || !w.scores[0].ok || !w.scores[1].ok) return "";
  const fitting::StereoFit& flat = w.scores[0].full;
  const fitting::StereoFit& bowed = w.scores[1].full;
  if (!flat.ok || !bowed.ok || flat.param_names != bowed.param_names) return "";
  std::ostringstream md;
  md << "\nHeld-out gain of the bow: " << FixedOrDash(w.gain_px, 4) << " +- " << FixedOrDash(w.gain_se_px, 4)
     << " px (flat - bowed held-out RMS). Its effect on the lens:\n\n";
  Table t{"board_warp_effect", "", {"parameter", "flat", "bowed", "bowed - flat", "in flat sigma"}, {}};
  for (size_t i = 0; i < flat.param_names.size(); ++i) {
    const std::string& n = flat.param_names[i];
    const std::string stem = n.substr(n.find('.') + 1);
    if (stem != "fx" && stem != "k1" && stem != "k2" && stem != "k3") continue;
    const int e = n.rfind("left.", 0) == 0 ? 0 : 1;
    const int k = static_cast<int>(i) - (e == 0 ? 0 : static_cast<int>(flat.cameras[0].params.size()));
    if (k < 0 || k >= static_cast<int>(flat.cameras[e].params.size())) continue;
    const double a = flat.cameras[e].params[k], b = bowed.cameras[e].params[k], sigma = flat.sigmas[i];
    t.rows.push_back({n,
                      FixedOrDash(a, 5),
                      FixedOrDash(b, 5),
                      FixedOrDash(b - a, 5),
                      std::isfinite(sigma) && sigma > 0 ? FixedOrDash((b - a) / sigma, 2) : "-"});
  }
  md << ToMarkdown(t);
  return md.str();
}

}  // namespace

std::string ImageSetReportMarkdown(const evaluation::ImageSetCalibration& c, const std::vector<std::string>& keys) {
  std::ostringstream md;
  md << "# Stereo calibration from images\n\n";
  md << SetVerdictMarkdown(c.set_verdict) << "\n";
  md << "Pairs used: " << c.fit.paired_frames.size() << "; RMS left " << FixedOrDash(c.fit.rms_px[0], 3)
     << " px, right " << FixedOrDash(c.fit.rms_px[1], 3) << " px, joint " << FixedOrDash(c.fit.rms_joint_px, 3)
     << " px; rectified |dy| mean " << FixedOrDash(c.fit.rectified_dy_mean_px, 3) << " px, max "
     << FixedOrDash(c.fit.rectified_dy_max_px, 3) << " px.\n\n";
  if (c.lens_choice) {
    const fitting::LensModelChoice& l = *c.lens_choice;
    md << "## Lens model: " << l.chosen_name << "\n\n" << l.reason << ".\n\n";
    if (!l.scores.empty()) {
      Table t{"lens_model_choice",
              "",
              {"model",
               "fit RMS (px)",
               "held-out RMS (px)",
               "held-out left / right (px)",
               "held-out corners",
               "per fold (px)"},
              {}};
      for (const auto& s : l.scores) {
        std::string folds;
        for (double f : s.fold_rms_px) {
          if (!folds.empty()) folds += ' ';
          folds += FixedOrDash(f, 3);
        }
        t.rows.push_back({s.name + (s.model == l.chosen ? " (chosen)" : ""),
                          FixedOrDash(s.fit_rms_px, 4),
                          s.ok ? FixedOrDash(s.heldout_rms_px, 4) : "failed: " + s.message,
                          FixedOrDash(s.heldout_rms_eye_px[0], 4) + " / " + FixedOrDash(s.heldout_rms_eye_px[1], 4),
                          std::to_string(s.num_heldout_corners),
                          folds});
      }
      md << ToMarkdown(t);
      md << "\nHeld-out RMS: each fold's pairs are left out of the fit, then placed by their board pose alone with "
            "the fitted cameras and extrinsics; a richer model that only fits the noise predicts them worse.\n\n";
    }
  }
  if (c.warp_choice) {
    const fitting::BoardWarpChoice& w = *c.warp_choice;
    md << "## Board: " << (w.bowed ? "bowed" : "flat") << "\n\n" << w.reason << ".\n\n";
    if (!w.scores.empty()) {
      Table t{
          "board_warp_choice", "", {"board", "fit RMS (px)", "held-out RMS (px)", "held-out left / right (px)"}, {}};
      for (const auto& s : w.scores)
        t.rows.push_back({s.name + ((s.name == "bowed") == w.bowed ? " (chosen)" : ""),
                          FixedOrDash(s.fit_rms_px, 4),
                          s.ok ? FixedOrDash(s.heldout_rms_px, 4) : "failed: " + s.message,
                          FixedOrDash(s.heldout_rms_eye_px[0], 4) + " / " + FixedOrDash(s.heldout_rms_eye_px[1], 4)});
      md << ToMarkdown(t);
      md << BowEffectMarkdown(w);
      md << "\nBowed: mrcal's two-parameter deflection of the board (stereo.board_warp_x/y below when chosen); each "
            "held-out pair is placed on the bow its training folds fitted.\n\n";
    }
  }
  Table params{"parameters", "", {"parameter", "value", "sigma", "unit", "note"}, {}};
  for (const auto& p : c.result.parameters)
    params.rows.push_back({p.name,
                           FixedOrDash(p.value, 4),
                           p.held ? "held" : (p.determined ? FixedOrDash(p.sigma, 4) : "not determined"),
                           p.unit,
                           p.note});
  md << ToMarkdown(params);
  const char* eye_name[2] = {"left", "right"};
  for (int e = 0; e < 2; ++e) {
    const evaluation::EyeCoverage& cov = c.coverage[e];
    md << "\n## " << eye_name[e] << " eye: coverage " << FixedOrDash(100 * cov.grid_fraction, 0)
       << " % of cells, radius " << FixedOrDash(100 * cov.max_radius_fraction, 0) << " %, tilt up to "
       << FixedOrDash(cov.max_tilt_deg, 1) << " deg, orientation spread " << FixedOrDash(cov.spread_deg, 1)
       << " deg\n\n";
    Table views{std::string(eye_name[e]) + "_views", "", {"frame", "pair", "RMS (px)", "tilt (deg)"}, {}};
    const fitting::IntrinsicsFit& f = c.fit.per_eye[e];
    for (size_t i = 0; i < f.frame_indices.size(); ++i) {
      const int fr = f.frame_indices[i];
      views.rows.push_back({std::to_string(fr),
                            fr >= 0 && fr < static_cast<int>(keys.size()) ? keys[fr] : "",
                            i < f.view_rms_px.size() ? FixedOrDash(f.view_rms_px[i], 3) : "-",
                            i < cov.tilt_deg.size() ? FixedOrDash(cov.tilt_deg[i], 1) : "-"});
    }
    md << ToMarkdown(views);
  }
  return md.str();
}

std::string RangeTableCsv(const std::vector<RangeMeasurement>& m) {
  std::ostringstream c;
  c << "name,status,true_cm,range_cm,error_cm,error_pct,sigma_cm,sigma_calib_cm,sigma_cov_cm,sigma_cv_cm,sigma_match_"
       "cm,z,"
       "disparity_px,sigma_disparity_px,dy_px,ncc,second_ncc,peak_ratio,lr_error_px,contrast,block_spread_px,roi_x,roi_"
       "y,"
       "roi_w,roi_h,ray_gap_mm,message\n";
  for (const auto& r : m) {
    const bool e = r.ok && r.has_truth();
    const cv::Rect& roi = r.match.template_roi;
    std::string msg = r.message;
    std::replace(msg.begin(), msg.end(), '"', '\'');
    c << r.name << "," << r.status << "," << (r.has_truth() ? FixedOrDash(r.true_m * 100, 2) : "") << ","
      << (r.ok ? FixedOrDash(r.range_m * 100, 3) : "") << "," << (e ? FixedOrDash(r.error_m() * 100, 3) : "") << ","
      << (e ? FixedOrDash(100 * r.error_m() / r.true_m, 3) : "") << "," << (r.ok ? FixedOrDash(r.sigma_m * 100, 3) : "")
      << "," << (r.ok ? FixedOrDash(r.sigma_calib_m * 100, 3) : "") << ","
      << (r.ok ? FixedOrDash(r.sigma_cov_m * 100, 3) : "") << "," << (r.ok ? FixedOrDash(r.sigma_cv_m * 100, 3) : "")
      << "," << (r.ok ? FixedOrDash(r.sigma_match_m * 100, 3) : "") << ","
      << (e ? FixedOrDash(r.error_m() / r.error_sigma_m(), 2) : "") << "," << FixedOrDash(r.match.disparity_px, 3)
      << "," << FixedOrDash(r.match.sigma_disparity_px, 3) << "," << FixedOrDash(r.match.dy_px, 2) << ","
      << FixedOrDash(r.match.ncc, 3) << "," << FixedOrDash(r.match.second_ncc, 3) << ","
      << FixedOrDash(r.match.peak_ratio, 3) << "," << FixedOrDash(r.match.lr_error_px, 2) << ","
      << FixedOrDash(r.match.contrast, 1) << "," << FixedOrDash(r.match.block_spread_px, 2) << "," << roi.x << ","
      << roi.y << "," << roi.width << "," << roi.height << "," << (r.ok ? FixedOrDash(r.ray_gap_m * 1000, 2) : "")
      << ",\"" << msg << "\"\n";
  }
  return c.str();
}

std::string RangeTableMarkdown(const std::vector<RangeMeasurement>& m,
                               const evaluation::RangeSummary& s,
                               const std::string& title) {
  std::ostringstream md;
  md << "# " << title << "\n\n";
  Table t{"ranges",
          "",
          {"pair",
           "status",
           "true (cm)",
           "range (cm)",
           "error (%)",
           "sigma (cm)",
           "sigma calib / match (cm)",
           "truth sigma (cm)",
           "error/sigma",
           "disparity (px)",
           "NCC",
           "why not ok"},
          {}};
  for (const auto& r : m) {
    const bool e = r.ok && r.has_truth();
    t.rows.push_back(
        {r.name,
         r.status,
         r.has_truth() ? FixedOrDash(r.true_m * 100, 1) : "unknown",
         r.ok ? FixedOrDash(r.range_m * 100, 2) : "-",
         e ? FixedOrDash(100 * r.error_m() / r.true_m, 2) : "-",
         r.ok ? FixedOrDash(r.sigma_m * 100, 2) : "-",
         r.ok ? FixedOrDash(r.sigma_calib_m * 100, 2) + " / " + FixedOrDash(r.sigma_match_m * 100, 2) : "-",
         FixedOrDash(r.truth_sigma_m * 100, 2),
         e ? FixedOrDash(r.error_m() / r.error_sigma_m(), 2) : "-",
         FixedOrDash(r.match.disparity_px, 2),
         FixedOrDash(r.match.ncc, 3),
         r.status == "ok" ? "" : r.message});
  }
  md << ToMarkdown(t);
  md << "\n"
     << s.num_ranged << " of " << s.num_rows << " rows with a truth ranged with confidence; " << s.num_low_confidence
     << " low confidence, " << s.num_failed << " failed (both left out of the errors), " << s.num_unknown
     << " of unknown distance. ";
  if (s.num_ranged > 0)
    md << "Mean |error| " << FixedOrDash(100 * s.mean_abs_rel, 2) << " %, max " << FixedOrDash(100 * s.max_abs_rel, 2)
       << " %; max |error|/sigma " << FixedOrDash(s.max_abs_z, 2) << "; " << s.num_outside_3sigma
       << " outside +-3 sigma (error/sigma uses sqrt(sigma^2 + truth sigma^2)).";
  if (s.num_flagged_ranged > 0)
    md << " The " << s.num_flagged_ranged << " low-confidence rows with a range, for comparison: mean |error| "
       << FixedOrDash(100 * s.mean_abs_rel_flagged, 2) << " %, max " << FixedOrDash(100 * s.max_abs_rel_flagged, 2)
       << " %.";
  md << "\n";
  return md.str();
}

std::string DatumFitMarkdown(const fitting::DatumFit& f) {
  std::ostringstream md;
  md << "## Datum and scale of the true distances\n\n";
  if (!f.ok) {
    md << "Not fitted: " << f.message << ".\n";
    return md.str();
  }
  md << "range = a + b * truth over " << f.num_rows << " confident rows: a = " << FixedOrDash(100 * f.a_m, 2) << " +- "
     << FixedOrDash(100 * f.sigma_a_m, 2) << " cm, b = " << FixedOrDash(f.b, 4) << " +- " << FixedOrDash(f.sigma_b, 4)
     << " (correlation " << FixedOrDash(f.correlation, 2) << "), chi2/dof " << FixedOrDash(f.chi2_per_dof, 2)
     << " (dof " << f.dof
     << "). A negative a means the ranges read short by a constant: the true distances were measured from "
     << "about " << FixedOrDash(100 * std::abs(f.a_m), 1) << " cm " << (f.a_m < 0 ? "behind" : "in front of")
     << " the cameras' optical centres; b - 1 is a scale error (focal length x baseline).\n\n";
  const Table t{"datum_fit",
                "",
                {"", "mean abs error", "max abs error"},
                {{"before the fit",
                  FixedOrDash(100 * f.mean_abs_rel_before, 2) + " %",
                  FixedOrDash(100 * f.max_abs_rel_before, 2) + " %"},
                 {"after the fit (in-sample)",
                  FixedOrDash(100 * f.mean_abs_rel_after, 2) + " %",
                  FixedOrDash(100 * f.max_abs_rel_after, 2) + " %"},
                 {"after, leave-one-out",
                  FixedOrDash(100 * f.mean_abs_rel_loo, 2) + " %",
                  FixedOrDash(100 * f.max_abs_rel_loo, 2) + " %"}}};
  md << ToMarkdown(t);
  return md.str();
}

std::string ScaleBudgetMarkdown(const evaluation::ScaleBudget& b) {
  std::ostringstream md;
  md << "## Where the scale goes\n\n";
  if (!b.ok) {
    md << b.Sentence() << "\n";
    return md.str();
  }
  auto pct = [](double v) { return FixedOrDash(100 * v, 2); };
  const Table t{"scale_budget",
                "",
                {"term", "share of b - 1 (%)", "sigma (%)", "how"},
                {{"fitted b - 1",
                  pct(b.b_minus_1),
                  pct(b.sigma_b),
                  "datum and scale fit, " + std::to_string(b.num_rows) + " rows"},
                 {"calibration (f x B), covariance",
                  "0",
                  pct(b.calib_sigma_cov),
                  "the calibration's covariance carried through the fit"},
                 {"calibration (f x B), halves",
                  "0",
                  pct(b.calib_sigma_cv),
                  "the two halves of the calibration set, each ranging the same matches"},
                 {"matching (disparity bias)",
                  pct(b.matching),
                  pct(b.matching_sigma),
                  "StereoSGBM's disparity at the same templates (" + std::to_string(b.matching_rows) +
                      " rows); sigma: a common " + FixedOrDash(b.subpixel_floor_px, 2) + " px bias"},
                 {"truth (datum, ruler, placement)", pct(b.truth), pct(b.truth_sigma), "the rest"}}};
  md << ToMarkdown(t) << "\n" << b.Sentence() << "\n";
  for (const auto& n : b.notes) md << "\n- " << n;
  if (!b.notes.empty()) md << "\n";
  return md.str();
}

}  // namespace owlcal::reports
