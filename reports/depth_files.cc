#include "reports/depth_files.h"

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

#include "fitting/format.h"
#include "io/json_strict.h"
#include "reports/point_cloud_ply.h"
#include "reports/table.h"

namespace owlcal::reports {
namespace {

namespace fs = std::filesystem;
using fitting::FixedOrDash;

void WriteImage(const fs::path& p, const cv::Mat& m) {
  if (!cv::imwrite(p.string(), m)) throw std::runtime_error(p.string() + ": cannot write image");
}

// One pair against its true distance: the figures of its depth.csv and depth.md rows [%, cm].
struct PairTruthErrors {
  double true_cm = 0;
  double err = NAN;   // SGBM depth error [%]
  double terr = NAN;  // template ranging error [%]
  double kerr = 0;    // K / disp16 error, K fitted on all pairs [%]
  double kloo = 0;    // the same, K fitted without this pair [%]
  double z = NAN;     // SGBM error / sqrt(sigma^2 + truth sigma^2)
};

void WriteDepthCsvRow(const evaluation::DepthPairResult& p,
                      const evaluation::DisparityConstantFit& k,
                      size_t i,
                      const PairTruthErrors& e,
                      std::ostringstream& csv) {
  const evaluation::RoiDepth& d = p.depth;
  const bool t_ok = p.templ && p.templ->ok;  // no template ranging without a true distance
  const double t_cm = t_ok ? p.templ->range_m * 100 : NAN;
  csv << p.name << "," << FixedOrDash(e.true_cm, 2) << "," << (d.ok ? FixedOrDash(d.depth_m * 100, 3) : "") << ","
      << (d.ok ? FixedOrDash(e.err, 3) : "") << "," << (d.ok ? FixedOrDash(d.sigma_m * 100, 3) : "") << ","
      << (d.ok ? FixedOrDash(d.sigma_calib_m * 100, 3) : "") << ","
      << (d.ok ? FixedOrDash(d.sigma_match_m * 100, 3) : "") << "," << FixedOrDash(d.valid_fraction(), 3) << ","
      << (d.ok ? FixedOrDash(d.disparity_px, 3) : "") << "," << FixedOrDash(e.z, 2) << ","
      << (d.ok ? FixedOrDash(d.disparity16, 0) : "") << "," << (d.ok ? FixedOrDash(d.disparity16 * e.true_cm, 0) : "")
      << "," << FixedOrDash(k.estimate_m[i] * 100, 3) << "," << FixedOrDash(e.kerr, 3) << "," << FixedOrDash(e.kloo, 3)
      << "," << (t_ok ? FixedOrDash(t_cm, 3) : "") << "," << (t_ok ? FixedOrDash(e.terr, 3) : "") << ","
      << (d.ok ? 1 : 0) << ",\"" << d.message << "\"\n";
}

void WriteDepthMdRow(const evaluation::DepthPairResult& p,
                     const evaluation::DisparityConstantFit& k,
                     size_t i,
                     const PairTruthErrors& e,
                     std::ostringstream& md) {
  const evaluation::RoiDepth& d = p.depth;
  const bool t_ok = p.templ && p.templ->ok;
  md << "| " << p.name << " | " << FixedOrDash(e.true_cm, 1) << " | "
     << (d.ok ? FixedOrDash(d.depth_m * 100, 2) : "refused") << " | " << FixedOrDash(e.err, 2) << " | "
     << (d.ok ? FixedOrDash(d.sigma_m * 100, 2) : "-") << " | " << FixedOrDash(e.z, 1) << " | "
     << FixedOrDash(d.valid_fraction(), 2) << " | " << (d.ok ? FixedOrDash(d.disparity16, 0) : "-") << " | "
     << (d.ok ? FixedOrDash(d.disparity16 * e.true_cm, 0) : "-") << " | " << FixedOrDash(k.estimate_m[i] * 100, 2)
     << " | " << FixedOrDash(e.kerr, 2) << " | " << (t_ok ? FixedOrDash(p.templ->range_m * 100, 2) : "-") << " | "
     << FixedOrDash(e.terr, 2) << " |\n";
}

}  // namespace

int WriteDepthImages(const fs::path& dir,
                     const evaluation::DepthMaps& maps,
                     const evaluation::DepthOptions& options,
                     double near_m,
                     double far_m,
                     bool ply,
                     const std::string& source) {
  fs::create_directories(dir);
  WriteImage(dir / "left_rect.png", maps.left_rect);
  WriteImage(dir / "right_rect.png", maps.right_rect);
  cv::Mat d16;  // 16-bit PNG of 16 d (invalid = 0), what the students read
  maps.disparity16.convertTo(d16, CV_16U);
  WriteImage(dir / "disparity16.png", d16);
  WriteImage(dir / "disparity.png", evaluation::ColourDisparity(maps, options.sgbm));
  WriteImage(dir / "depth_mm.png", evaluation::DepthMillimetres16(maps.depth_m));
  WriteImage(dir / "depth.png", evaluation::ColourDepth(maps.depth_m, near_m, far_m));
  return ply ? WritePointCloudPly((dir / "cloud.ply").string(), maps, options.max_depth_m, source) : 0;
}

nlohmann::json DepthRoiJson(const evaluation::RoiDepth& d) {
  return {{"ok", d.ok},
          {"message", d.message},
          {"roi", {d.roi.x, d.roi.y, d.roi.width, d.roi.height}},
          {"valid_fraction", d.valid_fraction()},
          {"disparity_px", io::JsonNumber(d.disparity_px)},
          {"disparity16", io::JsonNumber(d.disparity16)},
          {"scatter_px", io::JsonNumber(d.scatter_px)},
          {"sigma_disparity_px", io::JsonNumber(d.sigma_disparity_px)},
          {"depth_m", io::JsonNumber(d.depth_m)},
          {"sigma_m", io::JsonNumber(d.sigma_m)},
          {"sigma_match_m", io::JsonNumber(d.sigma_match_m)},
          {"sigma_calib_m", io::JsonNumber(d.sigma_calib_m)}};
}

nlohmann::json DepthPairJson(const evaluation::DepthPairResult& p) {
  nlohmann::json j = {{"name", p.name},
                      {"left", p.left_path},
                      {"right", p.right_path},
                      {"valid_fraction_image", p.valid_fraction_image},
                      {"points", p.points},
                      {"roi_depth", DepthRoiJson(p.depth)}};
  if (std::isfinite(p.true_m)) {
    j["true_m"] = p.true_m;
    const evaluation::RangeMeasurement& m = *p.templ;
    j["template_range_m"] = m.ok ? nlohmann::json(m.range_m) : nlohmann::json(nullptr);
    j["template_message"] = m.message;
  }
  return j;
}

nlohmann::json DepthReportHeader(const fitting::StereoRig& rig,
                                 const fitting::Rectification& rect,
                                 const evaluation::DepthOptions& o) {
  return {{"calibration", rig.source},
          {"rectified_focal_px", rect.focal_px},
          {"baseline_m", rect.baseline_m},
          {"frame", "left rectified camera: x right, y down, z forward [m]"},
          {"sgbm",
           {{"min_disparity", o.sgbm.min_disparity},
            {"num_disparities", o.sgbm.num_disparities},
            {"block_size", o.sgbm.block_size},
            {"P1", o.sgbm.P1()},
            {"P2", o.sgbm.P2()},
            {"disp12_max_diff", o.sgbm.disp12_max_diff},
            {"pre_filter_cap", o.sgbm.pre_filter_cap},
            {"uniqueness_ratio", o.sgbm.uniqueness_ratio},
            {"speckle_window_size", o.sgbm.speckle_window_size},
            {"speckle_range", o.sgbm.speckle_range},
            {"mode", o.sgbm.mode}}},
          {"rectify_alpha", o.rectify_alpha},
          {"pairs", nlohmann::json::array()}};
}

std::string WriteDepthTruthTables(const std::string& out_dir,
                                  const std::vector<evaluation::DepthPairResult>& pairs,
                                  const fitting::StereoRig& rig,
                                  const fitting::Rectification& rect,
                                  const evaluation::DepthOptions& o,
                                  double truth_sigma_cm,
                                  nlohmann::json* report) {
  const fs::path out(out_dir);
  std::vector<double> d16, truth;
  for (size_t i = 0; i < pairs.size(); ++i) {
    d16.push_back(pairs[i].depth.ok ? pairs[i].depth.disparity16 : std::numeric_limits<double>::quiet_NaN());
    truth.push_back(pairs[i].true_m);
  }
  const evaluation::DisparityConstantFit k =
      evaluation::FitDisparityConstant(d16, truth, rect.focal_px, rect.baseline_m);
  std::ostringstream csv, md;
  csv << "name,true_cm,depth_cm,error_pct,sigma_cm,sigma_calib_cm,sigma_match_cm,valid_fraction,disparity_px,"
         "z,disp16,disp16_x_cm,constant_estimate_cm,constant_error_pct,constant_loo_error_pct,template_cm,"
         "template_error_pct,ok,message\n";
  md << "# Depth at the target: SGBM vs the true distance\n\n"
     << "Calibration: " << rig.source << "; rectified f " << FixedOrDash(rect.focal_px, 2) << " px, baseline "
     << FixedOrDash(rect.baseline_m * 1000, 2) << " mm. Depth is from the optical centres along "
     << "the rectified axis (no datum offset). SGBM " << o.sgbm.num_disparities << " disparities, block "
     << o.sgbm.block_size << ", mode " << o.sgbm.mode << ".\n\n"
     << "| pair | true cm | SGBM cm | error % | sigma cm | z | valid | disp16 | disp16 x cm | K/disp16 cm | "
        "err % | template cm | err % |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  double sgbm_abs = 0, templ_abs = 0, sgbm_max = 0, templ_max = 0;
  int n_sgbm = 0, n_templ = 0, n_out3 = 0, n_known = 0, failed = 0;
  const double truth_sigma_m = truth_sigma_cm / 100;
  for (size_t i = 0; i < pairs.size(); ++i) {
    const auto& d = pairs[i].depth;
    const double true_m = pairs[i].true_m;
    // A blank distance in the truth CSV: measured and listed, left out of the error statistics.
    const bool known = std::isfinite(true_m);
    const bool t_ok = pairs[i].templ && pairs[i].templ->ok;
    n_known += known;
    failed += !d.ok;
    PairTruthErrors e;
    e.true_cm = true_m * 100;
    e.err = d.ok ? 100 * (d.depth_m - true_m) / true_m : NAN;
    e.terr = t_ok ? 100 * pairs[i].templ->error_m() / true_m : NAN;
    e.kerr = 100 * (k.estimate_m[i] - true_m) / true_m;
    e.kloo = 100 * (k.loo_estimate_m[i] - true_m) / true_m;
    // z: the error in units of the predicted sigma and the truth's own uncertainty together.
    e.z = d.ok ? (d.depth_m - true_m) / std::hypot(d.sigma_m, truth_sigma_m) : NAN;
    if (known && d.ok) sgbm_abs += std::abs(e.err), sgbm_max = std::max(sgbm_max, std::abs(e.err)), ++n_sgbm;
    if (known && d.ok && std::abs(e.z) > 3) ++n_out3;
    if (t_ok) templ_abs += std::abs(e.terr), templ_max = std::max(templ_max, std::abs(e.terr)), ++n_templ;
    WriteDepthCsvRow(pairs[i], k, i, e, csv);
    WriteDepthMdRow(pairs[i], k, i, e, md);
  }
  md << "\nSGBM: " << n_sgbm << " of " << n_known << " pairs with a true distance measured, mean |error| "
     << FixedOrDash(n_sgbm ? sgbm_abs / n_sgbm : NAN, 2) << " %, max " << FixedOrDash(sgbm_max, 2) << " %; " << n_out3
     << " outside +-3 sigma (z = error / sqrt(sigma^2 + truth sigma^2), truth sigma " << FixedOrDash(truth_sigma_cm, 1)
     << " cm)"
     << (n_out3 ? ": the predicted sigma does not cover these errors"
                  " (the truth's datum and placement? give --truth-sigma-cm)"
                : "")
     << ".\n"
     << "Template ranging (range-images, same ROI): " << n_templ << " of " << n_known << ", mean |error| "
     << FixedOrDash(n_templ ? templ_abs / n_templ : NAN, 2) << " %, max " << FixedOrDash(templ_max, 2) << " %.\n"
     << "Students' measure: disp16 x distance = K = " << FixedOrDash(k.k_disp16_m * 100, 0) << " (disp16 cm), spread "
     << FixedOrDash(k.k_cv_pct, 2) << " % over " << k.num_rows
     << " pairs; the calibration's 16 f B = " << FixedOrDash(k.k_calibration * 100, 0) << " ("
     << FixedOrDash(100 * (k.k_disp16_m / k.k_calibration - 1), 2) << " %). Distance = K / disp16: mean |error| "
     << FixedOrDash(k.mean_abs_pct, 2) << " %, max " << FixedOrDash(k.max_abs_pct, 2)
     << " % (K fitted on the same pairs); leave-one-out " << FixedOrDash(k.loo_mean_abs_pct, 2) << " %.\n";
  if (n_known < int(pairs.size()))
    md << "\n" << pairs.size() - n_known << " pair(s) without a true distance: measured, not in the errors.\n";
  if (failed) md << "\n" << failed << " pair(s) refused: see the message column of depth.csv.\n";
  WriteTextFile((out / "depth.csv").string(), csv.str());
  WriteTextFile((out / "depth.md").string(), md.str());
  (*report)["disparity_constant"] = {{"k_disp16_cm", k.k_disp16_m * 100},
                                     {"k_cv_pct", k.k_cv_pct},
                                     {"k_calibration_disp16_cm", k.k_calibration * 100},
                                     {"mean_abs_pct", k.mean_abs_pct},
                                     {"max_abs_pct", k.max_abs_pct},
                                     {"loo_mean_abs_pct", k.loo_mean_abs_pct}};
  return md.str();
}

}  // namespace owlcal::reports
