#include "pipeline/depth.h"

#include <cmath>
#include <filesystem>
#include <limits>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/image_pairs.h"
#include "evaluation/range_images_ranging.h"
#include "fitting/format.h"
#include "reports/depth_files.h"
#include "reports/table.h"

namespace owlcal::pipeline {
namespace {

namespace fs = std::filesystem;
using fitting::FixedOrDash;

void Load(const evaluation::DepthPairResult& j, const DepthRunOptions& a, cv::Mat* l, cv::Mat* r) {
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

// The pairs to measure, from the inputs (LEFT RIGHT, one frame, or a folder with a truth CSV)
// and the ROI (options checked).
std::vector<evaluation::DepthPairResult> PlanDepthJobs(const DepthRunOptions& a) {
  cv::Rect roi_opt;
  if (!a.roi.empty()) roi_opt = cv::Rect(a.roi[0], a.roi[1], a.roi[2], a.roi[3]);
  std::vector<evaluation::DepthPairResult> jobs;
  if (!a.truth.empty()) {
    for (const auto& t : evaluation::ReadRangeTruthCsv(a.truth)) {
      evaluation::DepthPairResult j;
      j.name = fs::path(t.left).stem().string();
      j.left_path = (fs::path(a.inputs[0]) / t.left).string();
      j.right_path = (fs::path(a.inputs[0]) / t.right).string();
      j.true_m = t.distance_m;
      j.roi = t.roi;
      jobs.push_back(j);
    }
  } else {
    evaluation::DepthPairResult j;
    j.name = a.inputs.size() == 2 ? "pair" : "frame";
    j.left_path = a.inputs[0];
    j.right_path = a.inputs.back();
    jobs.push_back(j);
  }
  if (roi_opt.area() > 0)
    for (evaluation::DepthPairResult& j : jobs) j.roi = roi_opt;
  return jobs;
}

// Rectifies one pair, writes its images (and cloud.ply) into dir and measures the depth at its
// ROI (default: 64 x 48 px at the image centre, as range-images); says one line.
void MeasurePairDepth(const DepthRunOptions& a,
                      const DepthRun& run,
                      const fs::path& dir,
                      const std::function<void(const std::string&)>& say,
                      evaluation::DepthPairResult* p) {
  const evaluation::DepthPairResult& j = *p;
  const fitting::StereoRig& rig = run.rig;
  const fitting::Rectification& rect = run.rect;
  cv::Mat l, r;
  Load(j, a, &l, &r);
  const evaluation::DepthMaps maps = evaluation::ComputeDepth(l, r, rect, a.depth);
  p->points = reports::WriteDepthImages(dir, maps, a.depth, a.near_m, a.far_m, a.ply, rig.source);
  p->valid_fraction_image = double(maps.num_valid) / maps.depth_m.total();
  cv::Rect roi = j.roi;
  if (roi.area() <= 0) roi = cv::Rect(maps.depth_m.cols / 2 - 32, maps.depth_m.rows / 2 - 24, 64, 48);
  p->depth = evaluation::DepthAtRoi(maps, roi, rig, rect, a.depth);
  const evaluation::RoiDepth& d = p->depth;
  if (std::isfinite(j.true_m)) {
    evaluation::RangeOptions ro;
    ro.match.template_roi = d.roi;
    ro.match.max_disparity = a.depth.sgbm.min_disparity + a.depth.sgbm.num_disparities;
    evaluation::RangeMeasurement m = evaluation::RangePair(l, r, rig, rect, ro);
    m.name = j.name;
    m.true_m = j.true_m;
    p->templ = m;
  }
  std::ostringstream line;
  line << j.name << ": " << int(100.0 * maps.num_valid / maps.depth_m.total()) << " % of pixels with depth; ROI ("
       << d.roi.x << "," << d.roi.y << " " << d.roi.width << "x" << d.roi.height << ") "
       << (d.ok ? "depth " + FixedOrDash(d.depth_m * 100, 2) + " +- " + FixedOrDash(d.sigma_m * 100, 2) +
                      " cm (disparity " + FixedOrDash(d.disparity_px, 2) + " px, 16-bit " +
                      FixedOrDash(d.disparity16, 0) + ")"
                : "refused: " + d.message)
       << (std::isfinite(j.true_m) ? ", true " + FixedOrDash(j.true_m * 100, 1) + " cm" : "");
  say(line.str());
}

}  // namespace

bool DepthRunOptions::Check(std::string* why) const {
  if (!depth.Check(why)) return false;
  if (!roi.empty() && (roi.size() != 4 || roi[2] <= 0 || roi[3] <= 0)) {
    *why = "--roi needs 4 numbers x y w h (w, h > 0)";
    return false;
  }
  if (!truth.empty()) {
    if (inputs.size() != 1 || !fs::is_directory(inputs[0])) {
      *why = "with --truth, give one folder holding the images the CSV names";
      return false;
    }
  } else if (!(inputs.size() == 2 || (inputs.size() == 1 && fs::is_regular_file(inputs[0])))) {
    *why = "give LEFT RIGHT images, one side-by-side frame, or a folder with --truth CSV";
    return false;
  }
  return true;
}

DepthRun RunDepth(const DepthRunOptions& a, const std::function<void(const std::string&)>& say) {
  std::string why;
  if (!a.Check(&why)) throw std::invalid_argument(why);
  DepthRun run;
  run.pairs = PlanDepthJobs(a);
  run.rig = fitting::LoadStereoRig(a.calib);
  run.rect = fitting::RectifyRig(run.rig, a.depth.rectify_alpha);
  fs::create_directories(a.out);
  const fs::path out(a.out);
  const bool many = run.pairs.size() > 1;
  nlohmann::json report = reports::DepthReportHeader(run.rig, run.rect, a.depth);
  for (evaluation::DepthPairResult& p : run.pairs) {
    MeasurePairDepth(a, run, many ? out / p.name : out, say, &p);
    if (!p.depth.ok) ++run.failed;
    report["pairs"].push_back(reports::DepthPairJson(p));
  }
  if (!a.truth.empty())
    run.truth_md =
        reports::WriteDepthTruthTables(a.out, run.pairs, run.rig, run.rect, a.depth, a.truth_sigma_cm, &report);
  reports::WriteTextFile((out / "depth.json").string(), report.dump(2) + "\n");
  return run;
}

}  // namespace owlcal::pipeline
