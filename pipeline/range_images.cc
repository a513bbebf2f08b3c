#include "pipeline/range_images.h"

#include <cmath>
#include <filesystem>
#include <limits>
#include <stdexcept>
#include <utility>

#include <opencv2/imgcodecs.hpp>

#include "calib/image_pairs.h"
#include "calib/template_roi.h"
#include "evaluation/range_scale_budget.h"
#include "fitting/format.h"
#include "reports/gnuplot_figure.h"
#include "reports/image_set_tables.h"
#include "reports/table.h"

namespace owlcal::pipeline {
namespace {

namespace fs = std::filesystem;

// The --select choice as template options; false (and why) for a bad one.
bool SelectOptions(const RangeImagesRunOptions& a, calib::TemplateRoiOptions* out, std::string* why) {
  calib::TemplateRoiOptions t;
  t.width = a.template_w;
  t.height = a.template_h;
  const std::string& s = a.select;
  if (s == "texture") {
    t.mode = "texture";
  } else if (s.rfind("colour:", 0) == 0 || s.rfind("color:", 0) == 0) {
    t.mode = "colour";
    t.colour = s.substr(s.find(':') + 1);
  } else if (s == "tag" || s.rfind("tag:", 0) == 0) {
    t.mode = "tag";
    if (s.size() > 4) {
      try {
        t.tag_id = std::stoi(s.substr(4));
      } catch (const std::exception&) {
        *why = "--select " + s + ": the tag id must be a number (tag:7)";
        return false;
      }
    }
  } else if (s != "centre") {
    *why = "--select = '" + s + "': use centre, texture, colour:red|green|blue|yellow, tag or tag:ID";
    return false;
  }
  if (!t.Check(why)) {
    *why = "--select: " + *why;
    return false;
  }
  *out = t;
  return true;
}

// Reads, rectifies and ranges the pair of one truth row (its ROI, --roi, the --select choice or
// the central region).
evaluation::RangeMeasurement RangePair(const RangeImagesRunOptions& a,
                                       const evaluation::RangeTruthRow& t,
                                       const evaluation::RangeOptions& o,
                                       const fitting::StereoRig& rig,
                                       const fitting::Rectification& rect,
                                       const calib::TemplateRoiOptions* sel) {
  evaluation::RangeOptions ro = o;
  if (t.roi.area() > 0) ro.match.template_roi = t.roi;
  const std::string lp = (fs::path(a.dir) / t.left).string(), rp = (fs::path(a.dir) / t.right).string();
  cv::Mat l = cv::imread(lp), r = cv::imread(rp);
  if (l.empty()) throw std::runtime_error(lp + ": cannot read image");
  if (r.empty()) throw std::runtime_error(rp + ": cannot read image");
  if (a.mirror) {
    cv::flip(l, l, 1);
    cv::flip(r, r, 1);
  }
  cv::Mat lr, rr;
  fitting::RemapPair(rect, l, r, &lr, &rr);
  std::string how = t.roi.area() > 0 ? "ROI from the truth file" : (a.roi.empty() ? "central region" : "--roi");
  bool have_roi = true;
  if (sel && t.roi.area() == 0 && a.roi.empty()) {
    const calib::TemplateRoiChoice c = calib::ChooseTemplateRois(lr, *sel);
    ro.candidate_rois = c.candidates;
    how = c.how;
    have_roi = !c.candidates.empty();
  }
  evaluation::RangeMeasurement m;
  if (have_roi) {
    m = evaluation::RangeRectifiedPair(lr, rr, rig, rect, ro);
  } else {
    m.status = "failed";
    m.message = "no target: " + how;
  }
  m.roi_how = how + (m.roi_how.empty() ? "" : ", " + m.roi_how);
  m.name = t.left;
  m.true_m = t.distance_m;
  m.truth_sigma_m = ro.truth_sigma_m;
  return m;
}

// The range figure: the error against the true distance (ok and low-confidence apart, after the
// datum fit too), or the ranges themselves when no distance is known.
reports::Figure RangeFigure(const std::vector<evaluation::RangeMeasurement>& ms,
                            const evaluation::RangeSummary& s,
                            const fitting::DatumFit& datum,
                            const std::vector<int>& datum_rows,
                            double truth_sigma_cm) {
  reports::Figure f;
  const bool any_truth = s.num_rows > 0;
  f.name = any_truth ? "range_error" : "range_values";  // not "ranges": ranges.csv is the table
  f.title = any_truth ? "Stereo range error vs true distance" : "Stereo ranges (distances unknown)";
  f.xlabel = any_truth ? "true distance [cm]" : "pair";
  f.ylabel = any_truth ? "error [%]" : "range [cm]";
  reports::Series band, ok, low, after;
  band.title = "true distance +-3 sigma";
  band.style = "filledcurves fs transparent solid 0.18 noborder lc rgb '#777777'";
  band.using_spec = "1:2:3";
  band.columns = {"true_cm", "lo_pct", "hi_pct"};
  ok.title = "ok, +-3 sigma predicted";
  ok.style = "yerrorbars pt 7 lc rgb '#1f77b4'";
  ok.using_spec = "1:2:3";
  ok.columns = {any_truth ? "true_cm" : "pair",
                any_truth ? "err_pct" : "range_cm",
                any_truth ? "three_sigma_pct" : "three_sigma_cm"};
  low = ok;
  low.title = "LOW CONFIDENCE (not counted), +-3 sigma";
  low.style = "yerrorbars pt 6 ps 1.5 lc rgb '#d62728'";
  after.title = "after the datum and scale fit";
  after.style = "points pt 9 lc rgb '#2ca02c'";
  after.using_spec = "1:2";
  after.columns = {"true_cm", "err_after_pct"};
  for (size_t i = 0; i < ms.size(); ++i) {
    const auto& m = ms[i];
    if (!m.ok) continue;
    reports::Series& target = m.status == "ok" ? ok : low;
    if (any_truth) {
      if (!m.has_truth()) continue;
      target.rows.push_back({m.true_m * 100, 100 * m.error_m() / m.true_m, 300 * m.sigma_m / m.true_m});
      if (m.status == "ok")
        band.rows.push_back({m.true_m * 100, -300 * m.truth_sigma_m / m.true_m, 300 * m.truth_sigma_m / m.true_m});
    } else {
      target.rows.push_back({static_cast<double>(i), m.range_m * 100, 300 * m.sigma_m});
    }
  }
  if (datum.ok)
    for (size_t k = 0; k < datum_rows.size(); ++k) {
      const auto& m = ms[datum_rows[k]];
      after.rows.push_back({m.true_m * 100, 100 * (datum.after_m[k] - m.true_m) / m.true_m});
    }
  if (any_truth && truth_sigma_cm > 0 && !band.rows.empty()) f.series.push_back(band);
  if (!ok.rows.empty()) f.series.push_back(ok);
  if (!low.rows.empty()) f.series.push_back(low);
  if (!after.rows.empty()) f.series.push_back(after);
  if (any_truth) f.settings.push_back("set xzeroaxis");
  return f;
}

}  // namespace

bool RangeImagesRunOptions::Check(std::string* why) const {
  if (!roi.empty() && roi.size() != 4) {
    *why = "--roi needs 4 numbers: x y w h";
    return false;
  }
  calib::TemplateRoiOptions t;
  return SelectOptions(*this, &t, why);
}

RangeImagesRun RunRangeImages(const RangeImagesRunOptions& a, const std::function<void(const std::string&)>& progress) {
  std::string why;
  if (!a.Check(&why)) throw std::invalid_argument(why);
  const fitting::StereoRig rig = fitting::LoadStereoRig(a.calib);
  const fitting::Rectification rect = fitting::RectifyRig(rig);
  std::vector<evaluation::RangeTruthRow> truth;
  if (!a.truth.empty()) {
    truth = evaluation::ReadRangeTruthCsv(a.truth);
  } else {
    // No truth file: every left*/right* pair of the folder, distance unknown.
    calib::ImagePairOptions po;
    for (const auto& p : calib::ListImagePairs(a.dir, po).pairs) {
      evaluation::RangeTruthRow r;
      r.left = fs::path(p.left_path).filename().string();
      r.right = fs::path(p.right_path).filename().string();
      r.distance_m = std::numeric_limits<double>::quiet_NaN();
      truth.push_back(r);
    }
  }
  evaluation::RangeOptions o;
  o.truth_sigma_m = a.truth_sigma_cm / 100;
  o.datum_offset_m = a.datum_cm / 100;
  o.match.template_width = a.template_w;
  o.match.template_height = a.template_h;
  o.match.max_disparity = a.max_disparity;
  // A template ROI must lie inside the left rectified image: refused, never clipped or moved.
  if (!a.roi.empty()) {
    o.match.template_roi = cv::Rect(a.roi[0], a.roi[1], a.roi[2], a.roi[3]);
    if (!evaluation::RoiInsideImage(o.match.template_roi, rect.size))
      throw std::invalid_argument("--roi " + std::to_string(a.roi[0]) + " " + std::to_string(a.roi[1]) + " " +
                                  std::to_string(a.roi[2]) + " " + std::to_string(a.roi[3]) +
                                  " is not a template (w, h >= 5) inside the " + std::to_string(rect.size.width) + "x" +
                                  std::to_string(rect.size.height) + " rectified image");
  }
  evaluation::CheckRangeTruthRois(truth, rect.size);
  const bool auto_select = a.select != "centre";
  calib::TemplateRoiOptions sel;
  if (auto_select) SelectOptions(a, &sel, &why);
  if (!o.Check(&why)) throw std::invalid_argument(why);
  std::vector<evaluation::RangeMeasurement> ms;
  for (const auto& t : truth) {
    ms.push_back(RangePair(a, t, o, rig, rect, auto_select ? &sel : nullptr));
    // A long list prints a progress line every kProgressEveryPairs pairs (each is read, rectified, matched).
    if (truth.size() > kRangeProgressEveryPairs && ms.size() % kRangeProgressEveryPairs == 0)
      progress("range-images: " + std::to_string(ms.size()) + " of " + std::to_string(truth.size()) + " pairs ranged");
  }
  const evaluation::RangeSummary s = evaluation::SummariseRanges(ms);
  fs::create_directories(a.out);
  const fs::path out(a.out);
  std::string md = reports::RangeTableMarkdown(ms, s, "Range from stereo images: " + a.dir);
  // Datum and scale of the truth, from the confident rows.
  fitting::DatumFit datum;
  std::vector<int> datum_rows;
  if (!a.no_datum_fit && s.num_ranged > 0) {
    std::vector<fitting::DatumFitRow> rows;
    for (size_t i = 0; i < ms.size(); ++i) {
      if (ms[i].status != "ok" || !ms[i].has_truth()) continue;
      rows.push_back({ms[i].range_m, ms[i].true_m, ms[i].sigma_m, ms[i].truth_sigma_m});
      datum_rows.push_back(static_cast<int>(i));
    }
    datum = fitting::FitDatum(rows);
    md += "\n" + reports::DatumFitMarkdown(datum);
    if (datum.ok) {
      // The second matcher's disparity at each template (the cross-check's), for the matching term.
      std::vector<double> second_disparity;
      for (const auto& m : ms) second_disparity.push_back(m.second_disparity_px);
      const evaluation::ScaleBudget budget =
          evaluation::SplitScale(ms, datum_rows, datum, rig, rect, second_disparity, o.match.subpixel_floor_px);
      md += "\n" + reports::ScaleBudgetMarkdown(budget);
      reports::WriteTextFile((out / "scale_budget.json").string(),
                             evaluation::ScaleBudgetToJson(budget).dump(2) + "\n");
    }
  }
  md += "\nTemplates: " + std::string(auto_select ? "chosen per pair (" + a.select + "): " : "") +
        (ms.empty() ? std::string("-") : ms.front().roi_how) + (ms.size() > 1 ? " (first pair)" : "") + ".\n";
  md += "\nCalibration: " + rig.source + (rig.covariance.size() ? "" : " (no covariance)") +
        (rig.halves.empty() ? "; no halves (sigma_cv unknown)" : "; with its two halves (sigma_cv)") +
        "; rectified f " + fitting::FixedOrDash(rect.focal_px, 2) + " px, baseline " +
        fitting::FixedOrDash(rect.baseline_m * 1000, 3) +
        " mm. Range = depth from the optical centres along the rectified axis + datum " +
        fitting::FixedOrDash(a.datum_cm, 1) + " cm; truth sigma " + fitting::FixedOrDash(a.truth_sigma_cm, 1) +
        " cm (the uncertainty of the true distances themselves: datum and placement).\n";
  reports::WriteTextFile((out / "ranges.md").string(), md);
  reports::WriteTextFile((out / "ranges.csv").string(), reports::RangeTableCsv(ms));
  const reports::Figure f = RangeFigure(ms, s, datum, datum_rows, a.truth_sigma_cm);
  RangeImagesRun run;
  run.figure = f.name;
  if (!f.series.empty()) {
    const auto ff = reports::WriteFigure(f, a.out);
    run.figure_drawn = ff.drawn;
    if (!ff.drawn) run.figure_error = ff.message;
  }
  run.ranges = std::move(ms);
  run.summary = s;
  run.datum = datum;
  run.markdown = std::move(md);
  return run;
}

}  // namespace owlcal::pipeline
