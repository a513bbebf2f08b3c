// owlcal depth: dense disparity and depth from stereo pairs with a calibration (the course's
// stereo_match exercise): rectify, StereoSGBM, disparity and depth images, a PLY point cloud,
// the depth at a ROI with sigma; with a truth CSV also the error per pair, the template
// ranging of range-images beside it, and the students' "16-bit disparity x distance = constant".
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "apps/command_registry.h"
#include "calib/image_pairs.h"
#include "evaluation/range_images_ranging.h"
#include "evaluation/stereo_depth.h"
#include "fitting/format.h"
#include "io/json_strict.h"
#include "reports/point_cloud_ply.h"
#include "reports/table.h"

namespace owlcal::apps {
namespace {

namespace fs = std::filesystem;
using fitting::FixedOrDash;

struct DepthCmdOptions {
  std::vector<std::string> inputs;  // LEFT RIGHT, one side-by-side frame, or a folder with --truth
  std::string calib, truth, out;
  std::vector<int> roi;
  bool mirror = false, swap = false, ply = true;
  double near_m = 0.2, far_m = 2.0;
  double truth_sigma_cm = 0;
  evaluation::DepthOptions depth;
};

struct PairJob {
  std::string name, left_path, right_path;
  double true_m = std::numeric_limits<double>::quiet_NaN();
  cv::Rect roi;
};

void Load(const PairJob& j, const DepthCmdOptions& a, cv::Mat* l, cv::Mat* r) {
  if (j.left_path == j.right_path) {  // one side-by-side stream frame
    const cv::Mat f = cv::imread(j.left_path);
    if (f.empty()) throw std::runtime_error(j.left_path + ": cannot read image");
    if (f.cols % 2)
      throw std::runtime_error(j.left_path + ": a side-by-side frame needs an even width, got " +
                               std::to_string(f.cols));
    calib::SplitStereoFrame(f, a.mirror, a.swap, l, r);
    return;
  }
  *l = cv::imread(j.left_path);
  *r = cv::imread(j.right_path);
  if (l->empty()) throw std::runtime_error(j.left_path + ": cannot read image");
  if (r->empty()) throw std::runtime_error(j.right_path + ": cannot read image");
  if (a.mirror) {
    cv::flip(*l, *l, 1);
    cv::flip(*r, *r, 1);
  }
  if (a.swap) std::swap(*l, *r);
}

void WriteImage(const fs::path& p, const cv::Mat& m) {
  if (!cv::imwrite(p.string(), m)) throw std::runtime_error(p.string() + ": cannot write image");
}

nlohmann::json RoiJson(const evaluation::RoiDepth& d) {
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

// The pairs to measure, from the inputs (LEFT RIGHT, one frame, or a folder with --truth) and
// --roi; throws UsageError for a bad combination.
std::vector<PairJob> PlanDepthJobs(const DepthCmdOptions& a) {
  cv::Rect roi_opt;
  if (!a.roi.empty()) {
    if (a.roi.size() != 4 || a.roi[2] <= 0 || a.roi[3] <= 0)
      throw UsageError("--roi needs 4 numbers x y w h (w, h > 0)");
    roi_opt = cv::Rect(a.roi[0], a.roi[1], a.roi[2], a.roi[3]);
  }
  std::vector<PairJob> jobs;
  if (!a.truth.empty()) {
    if (a.inputs.size() != 1 || !fs::is_directory(a.inputs[0]))
      throw UsageError("with --truth, give one folder holding the images the CSV names");
    for (const auto& t : evaluation::ReadRangeTruthCsv(a.truth)) {
      PairJob j;
      j.name = fs::path(t.left).stem().string();
      j.left_path = (fs::path(a.inputs[0]) / t.left).string();
      j.right_path = (fs::path(a.inputs[0]) / t.right).string();
      j.true_m = t.distance_m;
      j.roi = t.roi;
      jobs.push_back(j);
    }
  } else if (a.inputs.size() == 2) {
    jobs.push_back({"pair", a.inputs[0], a.inputs[1], std::numeric_limits<double>::quiet_NaN(), {}});
  } else if (a.inputs.size() == 1 && fs::is_regular_file(a.inputs[0])) {
    jobs.push_back({"frame", a.inputs[0], a.inputs[0], std::numeric_limits<double>::quiet_NaN(), {}});
  } else {
    throw UsageError("give LEFT RIGHT images, one side-by-side frame, or a folder with --truth CSV");
  }
  if (roi_opt.area() > 0)
    for (PairJob& j : jobs) j.roi = roi_opt;
  return jobs;
}

// depth.json without its pairs: the calibration, the rectified geometry and the SGBM settings.
nlohmann::json DepthReportHeader(const DepthCmdOptions& a,
                                 const fitting::StereoRig& rig,
                                 const fitting::Rectification& rect) {
  return {{"calibration", rig.source},
          {"rectified_focal_px", rect.focal_px},
          {"baseline_m", rect.baseline_m},
          {"frame", "left rectified camera: x right, y down, z forward [m]"},
          {"sgbm",
           {{"min_disparity", a.depth.sgbm.min_disparity},
            {"num_disparities", a.depth.sgbm.num_disparities},
            {"block_size", a.depth.sgbm.block_size},
            {"P1", a.depth.sgbm.P1()},
            {"P2", a.depth.sgbm.P2()},
            {"disp12_max_diff", a.depth.sgbm.disp12_max_diff},
            {"pre_filter_cap", a.depth.sgbm.pre_filter_cap},
            {"uniqueness_ratio", a.depth.sgbm.uniqueness_ratio},
            {"speckle_window_size", a.depth.sgbm.speckle_window_size},
            {"speckle_range", a.depth.sgbm.speckle_range},
            {"mode", a.depth.sgbm.mode}}},
          {"rectify_alpha", a.depth.rectify_alpha},
          {"pairs", nlohmann::json::array()}};
}

// One pair measured: the depth at its ROI and, with a true distance, range-images' template
// ranging on the same ROI.
struct PairDepth {
  evaluation::RoiDepth roi;
  std::optional<evaluation::RangeMeasurement> templ;  // with a true distance only
  nlohmann::json json;                                // its entry in depth.json's pairs
};

// Rectifies one pair, writes its images (and cloud.ply) into dir and measures the depth at its
// ROI (default: 64 x 48 px at the image centre, as range-images); prints one line.
PairDepth MeasurePairDepth(const PairJob& j,
                           const DepthCmdOptions& a,
                           const fitting::StereoRig& rig,
                           const fitting::Rectification& rect,
                           const fs::path& dir) {
  cv::Mat l, r;
  Load(j, a, &l, &r);
  const evaluation::DepthMaps maps = evaluation::ComputeDepth(l, r, rect, a.depth);
  fs::create_directories(dir);
  WriteImage(dir / "left_rect.png", maps.left_rect);
  WriteImage(dir / "right_rect.png", maps.right_rect);
  cv::Mat d16;  // 16-bit PNG of 16 d (invalid = 0), what the students read
  maps.disparity16.convertTo(d16, CV_16U);
  WriteImage(dir / "disparity16.png", d16);
  WriteImage(dir / "disparity.png", evaluation::ColourDisparity(maps, a.depth.sgbm));
  WriteImage(dir / "depth_mm.png", evaluation::DepthMillimetres16(maps.depth_m));
  WriteImage(dir / "depth.png", evaluation::ColourDepth(maps.depth_m, a.near_m, a.far_m));
  int num_points = 0;
  if (a.ply)
    num_points = reports::WritePointCloudPly((dir / "cloud.ply").string(), maps, a.depth.max_depth_m, rig.source);
  cv::Rect roi = j.roi;
  if (roi.area() <= 0) roi = cv::Rect(maps.depth_m.cols / 2 - 32, maps.depth_m.rows / 2 - 24, 64, 48);
  PairDepth p;
  p.roi = evaluation::DepthAtRoi(maps, roi, rig, rect, a.depth);
  const evaluation::RoiDepth& d = p.roi;
  p.json = {{"name", j.name},
            {"left", j.left_path},
            {"right", j.right_path},
            {"valid_fraction_image", double(maps.num_valid) / maps.depth_m.total()},
            {"points", num_points},
            {"roi_depth", RoiJson(d)}};
  if (std::isfinite(j.true_m)) {
    p.json["true_m"] = j.true_m;
    evaluation::RangeOptions ro;
    ro.match.template_roi = d.roi;
    ro.match.max_disparity = a.depth.sgbm.min_disparity + a.depth.sgbm.num_disparities;
    evaluation::RangeMeasurement m = evaluation::RangePair(l, r, rig, rect, ro);
    m.name = j.name;
    m.true_m = j.true_m;
    p.json["template_range_m"] = m.ok ? nlohmann::json(m.range_m) : nlohmann::json(nullptr);
    p.json["template_message"] = m.message;
    p.templ = m;
  }
  std::cout << j.name << ": " << int(100.0 * maps.num_valid / maps.depth_m.total()) << " % of pixels with depth; ROI ("
            << d.roi.x << "," << d.roi.y << " " << d.roi.width << "x" << d.roi.height << ") "
            << (d.ok ? "depth " + FixedOrDash(d.depth_m * 100, 2) + " +- " + FixedOrDash(d.sigma_m * 100, 2) +
                           " cm (disparity " + FixedOrDash(d.disparity_px, 2) + " px, 16-bit " +
                           FixedOrDash(d.disparity16, 0) + ")"
                     : "refused: " + d.message)
            << (std::isfinite(j.true_m) ? ", true " + FixedOrDash(j.true_m * 100, 1) + " cm" : "") << "\n";
  return p;
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

void WriteDepthCsvRow(const PairJob& job,
                      const PairDepth& p,
                      const evaluation::DisparityConstantFit& k,
                      size_t i,
                      const PairTruthErrors& e,
                      std::ostringstream& csv) {
  const evaluation::RoiDepth& d = p.roi;
  const evaluation::RangeMeasurement& t = *p.templ;
  csv << job.name << "," << FixedOrDash(e.true_cm, 2) << "," << (d.ok ? FixedOrDash(d.depth_m * 100, 3) : "") << ","
      << (d.ok ? FixedOrDash(e.err, 3) : "") << "," << (d.ok ? FixedOrDash(d.sigma_m * 100, 3) : "") << ","
      << (d.ok ? FixedOrDash(d.sigma_calib_m * 100, 3) : "") << ","
      << (d.ok ? FixedOrDash(d.sigma_match_m * 100, 3) : "") << "," << FixedOrDash(d.valid_fraction(), 3) << ","
      << (d.ok ? FixedOrDash(d.disparity_px, 3) : "") << "," << FixedOrDash(e.z, 2) << ","
      << (d.ok ? FixedOrDash(d.disparity16, 0) : "") << "," << (d.ok ? FixedOrDash(d.disparity16 * e.true_cm, 0) : "")
      << "," << FixedOrDash(k.estimate_m[i] * 100, 3) << "," << FixedOrDash(e.kerr, 3) << "," << FixedOrDash(e.kloo, 3)
      << "," << (t.ok ? FixedOrDash(t.range_m * 100, 3) : "") << "," << (t.ok ? FixedOrDash(e.terr, 3) : "") << ","
      << (d.ok ? 1 : 0) << ",\"" << d.message << "\"\n";
}

void WriteDepthMdRow(const PairJob& job,
                     const PairDepth& p,
                     const evaluation::DisparityConstantFit& k,
                     size_t i,
                     const PairTruthErrors& e,
                     std::ostringstream& md) {
  const evaluation::RoiDepth& d = p.roi;
  const evaluation::RangeMeasurement& t = *p.templ;
  md << "| " << job.name << " | " << FixedOrDash(e.true_cm, 1) << " | "
     << (d.ok ? FixedOrDash(d.depth_m * 100, 2) : "refused") << " | " << FixedOrDash(e.err, 2) << " | "
     << (d.ok ? FixedOrDash(d.sigma_m * 100, 2) : "-") << " | " << FixedOrDash(e.z, 1) << " | "
     << FixedOrDash(d.valid_fraction(), 2) << " | " << (d.ok ? FixedOrDash(d.disparity16, 0) : "-") << " | "
     << (d.ok ? FixedOrDash(d.disparity16 * e.true_cm, 0) : "-") << " | " << FixedOrDash(k.estimate_m[i] * 100, 2)
     << " | " << FixedOrDash(e.kerr, 2) << " | " << (t.ok ? FixedOrDash(t.range_m * 100, 2) : "-") << " | "
     << FixedOrDash(e.terr, 2) << " |\n";
}

// With --truth: depth.csv and depth.md (the error per pair, template ranging beside it, the
// students' disp16 x distance = constant), their summary printed and added to depth.json.
void WriteDepthTruthTables(const DepthCmdOptions& a,
                           const std::vector<PairJob>& jobs,
                           const std::vector<PairDepth>& pairs,
                           const fitting::StereoRig& rig,
                           const fitting::Rectification& rect,
                           int failed,
                           nlohmann::json* report) {
  const fs::path out(a.out);
  std::vector<double> d16, truth;
  for (size_t i = 0; i < jobs.size(); ++i) {
    d16.push_back(pairs[i].roi.ok ? pairs[i].roi.disparity16 : std::numeric_limits<double>::quiet_NaN());
    truth.push_back(jobs[i].true_m);
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
     << "the rectified axis (no datum offset). SGBM " << a.depth.sgbm.num_disparities << " disparities, block "
     << a.depth.sgbm.block_size << ", mode " << a.depth.sgbm.mode << ".\n\n"
     << "| pair | true cm | SGBM cm | error % | sigma cm | z | valid | disp16 | disp16 x cm | K/disp16 cm | "
        "err % | template cm | err % |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  double sgbm_abs = 0, templ_abs = 0, sgbm_max = 0, templ_max = 0;
  int n_sgbm = 0, n_templ = 0, n_out3 = 0;
  const double truth_sigma_m = a.truth_sigma_cm / 100;
  for (size_t i = 0; i < jobs.size(); ++i) {
    const auto& d = pairs[i].roi;
    const auto& t = *pairs[i].templ;
    const double true_m = jobs[i].true_m;
    PairTruthErrors e;
    e.true_cm = true_m * 100;
    e.err = d.ok ? 100 * (d.depth_m - true_m) / true_m : NAN;
    e.terr = t.ok ? 100 * t.error_m() / t.true_m : NAN;
    e.kerr = 100 * (k.estimate_m[i] - true_m) / true_m;
    e.kloo = 100 * (k.loo_estimate_m[i] - true_m) / true_m;
    // z: the error in units of the predicted sigma and the truth's own uncertainty together.
    e.z = d.ok ? (d.depth_m - true_m) / std::hypot(d.sigma_m, truth_sigma_m) : NAN;
    if (d.ok) sgbm_abs += std::abs(e.err), sgbm_max = std::max(sgbm_max, std::abs(e.err)), ++n_sgbm;
    if (d.ok && std::abs(e.z) > 3) ++n_out3;
    if (t.ok) templ_abs += std::abs(e.terr), templ_max = std::max(templ_max, std::abs(e.terr)), ++n_templ;
    WriteDepthCsvRow(jobs[i], pairs[i], k, i, e, csv);
    WriteDepthMdRow(jobs[i], pairs[i], k, i, e, md);
  }
  md << "\nSGBM: " << n_sgbm << " of " << jobs.size() << " pairs measured, mean |error| "
     << FixedOrDash(n_sgbm ? sgbm_abs / n_sgbm : NAN, 2) << " %, max " << FixedOrDash(sgbm_max, 2) << " %; " << n_out3
     << " outside +-3 sigma (z = error / sqrt(sigma^2 + truth sigma^2), truth sigma "
     << FixedOrDash(a.truth_sigma_cm, 1) << " cm)"
     << (n_out3 ? ": the predicted sigma does not cover these errors"
                  " (the truth's datum and placement? give --truth-sigma-cm)"
                : "")
     << ".\n"
     << "Template ranging (range-images, same ROI): " << n_templ << " of " << jobs.size() << ", mean |error| "
     << FixedOrDash(n_templ ? templ_abs / n_templ : NAN, 2) << " %, max " << FixedOrDash(templ_max, 2) << " %.\n"
     << "Students' measure: disp16 x distance = K = " << FixedOrDash(k.k_disp16_m * 100, 0) << " (disp16 cm), spread "
     << FixedOrDash(k.k_cv_pct, 2) << " % over " << k.num_rows
     << " pairs; the calibration's 16 f B = " << FixedOrDash(k.k_calibration * 100, 0) << " ("
     << FixedOrDash(100 * (k.k_disp16_m / k.k_calibration - 1), 2) << " %). Distance = K / disp16: mean |error| "
     << FixedOrDash(k.mean_abs_pct, 2) << " %, max " << FixedOrDash(k.max_abs_pct, 2)
     << " % (K fitted on the same pairs); leave-one-out " << FixedOrDash(k.loo_mean_abs_pct, 2) << " %.\n";
  if (failed) md << "\n" << failed << " pair(s) refused: see the message column of depth.csv.\n";
  reports::WriteTextFile((out / "depth.csv").string(), csv.str());
  reports::WriteTextFile((out / "depth.md").string(), md.str());
  (*report)["disparity_constant"] = {{"k_disp16_cm", k.k_disp16_m * 100},
                                     {"k_cv_pct", k.k_cv_pct},
                                     {"k_calibration_disp16_cm", k.k_calibration * 100},
                                     {"mean_abs_pct", k.mean_abs_pct},
                                     {"max_abs_pct", k.max_abs_pct},
                                     {"loo_mean_abs_pct", k.loo_mean_abs_pct}};
  std::cout << "\n" << md.str();
}

int RunDepth(const DepthCmdOptions& a) {
  std::string why;
  if (!a.depth.Check(&why)) throw UsageError(why);
  const std::vector<PairJob> jobs = PlanDepthJobs(a);
  const fitting::StereoRig rig = fitting::LoadStereoRig(a.calib);
  const fitting::Rectification rect = fitting::RectifyRig(rig, a.depth.rectify_alpha);
  fs::create_directories(a.out);
  const fs::path out(a.out);
  const bool many = jobs.size() > 1;
  nlohmann::json report = DepthReportHeader(a, rig, rect);
  std::vector<PairDepth> pairs;
  int failed = 0;
  for (const PairJob& j : jobs) {
    pairs.push_back(MeasurePairDepth(j, a, rig, rect, many ? out / j.name : out));
    if (!pairs.back().roi.ok) ++failed;
    report["pairs"].push_back(pairs.back().json);
  }
  if (!a.truth.empty()) WriteDepthTruthTables(a, jobs, pairs, rig, rect, failed, &report);
  reports::WriteTextFile((out / "depth.json").string(), report.dump(2) + "\n");
  std::cout << "wrote " << a.out << (many ? "/<pair>/" : "/")
            << ": left_rect.png right_rect.png disparity16.png disparity.png depth_mm.png depth.png"
            << (a.ply ? " cloud.ply" : "") << "; depth.json" << (a.truth.empty() ? "" : " depth.csv depth.md") << "\n";
  if (failed) std::cerr << failed << " of " << jobs.size() << " ROI depth(s) refused (see depth.json)\n";
  return failed ? kExitFailed : kExitOk;
}

const bool kDepthRegistered = RegisterCommand(
    "depth",
    "Dense disparity and depth with a calibration (results.json, calibration.yaml or the course's\n"
    "intrinsics.xml + extrinsics.xml): rectify, StereoSGBM, write rectified images, disparity (16-bit and\n"
    "colour), depth (16-bit mm and colour), a PLY point cloud and the depth at a ROI with sigma (depth.json).\n"
    "Inputs: LEFT RIGHT images, one side-by-side frame, or a folder with --truth CSV\n"
    "(left,right,distance_cm[,roi_x,roi_y,roi_w,roi_h]): then also depth.csv/.md with the error per pair,\n"
    "range-images' template ranging beside it, and the students' disp16 x distance = constant.",
    [](CLI::App* cmd) {
      auto o = std::make_shared<DepthCmdOptions>();
      evaluation::SgbmOptions& s = o->depth.sgbm;
      cmd->add_option("inputs", o->inputs, "LEFT RIGHT, FRAME (side by side), or FOLDER with --truth")->required();
      cmd->add_option("--calib", o->calib, "calibration file or folder")->required();
      cmd->add_option("--out", o->out, "output folder")->required();
      cmd->add_option("--truth", o->truth, "truth CSV (a folder of pairs at known distances)")
          ->check(CLI::ExistingFile);
      cmd->add_option("--truth-sigma-cm", o->truth_sigma_cm, "uncertainty of the true distances [cm]")
          ->capture_default_str();
      cmd->add_option("--roi", o->roi, "x y w h in the left rectified image (default: 64x48 at the centre)")
          ->expected(4);
      cmd->add_option("--min-disparity", s.min_disparity, "SGBM minDisparity [px]")->capture_default_str();
      cmd->add_option("--num-disparities", s.num_disparities, "SGBM numDisparities (multiple of 16)")
          ->capture_default_str();
      cmd->add_option("--block-size", s.block_size, "SGBM blockSize (odd)")->capture_default_str();
      cmd->add_option("--p1", s.p1, "SGBM P1 (0 = 8 blockSize^2)")->capture_default_str();
      cmd->add_option("--p2", s.p2, "SGBM P2 (0 = 32 blockSize^2)")->capture_default_str();
      cmd->add_option("--disp12-max-diff", s.disp12_max_diff, "SGBM left-right check [px], < 0 off")
          ->capture_default_str();
      cmd->add_option("--pre-filter-cap", s.pre_filter_cap, "SGBM preFilterCap")->capture_default_str();
      cmd->add_option("--uniqueness", s.uniqueness_ratio, "SGBM uniquenessRatio [%]")->capture_default_str();
      cmd->add_option("--speckle-window", s.speckle_window_size, "SGBM speckleWindowSize")->capture_default_str();
      cmd->add_option("--speckle-range", s.speckle_range, "SGBM speckleRange")->capture_default_str();
      cmd->add_option("--mode", s.mode, "SGBM mode: sgbm, hh, 3way, hh4")->capture_default_str();
      cmd->add_option("--alpha", o->depth.rectify_alpha, "stereoRectify alpha (-1 default, 0..1)")
          ->capture_default_str();
      cmd->add_option("--near-m", o->near_m, "colour scale of depth.png: nearest [m]")->capture_default_str();
      cmd->add_option("--far-m", o->far_m, "colour scale of depth.png: farthest [m]")->capture_default_str();
      cmd->add_option("--max-depth-m", o->depth.max_depth_m, "farthest point written to cloud.ply [m]")
          ->capture_default_str();
      cmd->add_flag("!--no-ply", o->ply, "do not write cloud.ply");
      cmd->add_flag("--mirror", o->mirror, "flip each image (or frame) horizontally first");
      cmd->add_flag("--swap", o->swap, "exchange the eyes");
      return [o] { return RunDepth(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
