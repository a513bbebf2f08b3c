// owlcal range-images DIR --calib FILE --truth CSV --out OUT: range a target in stereo pairs
// at known distances and report the error against the truth with predicted sigma (issue 7,
// item 3).
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include <opencv2/imgcodecs.hpp>

#include "apps/command_registry.h"
#include "fitting/format.h"
#include "fitting/range_images_ranging.h"
#include "reports/gnuplot_figure.h"
#include "reports/image_set_tables.h"

namespace owlcal::apps {
namespace {

namespace fs = std::filesystem;

struct RangeImagesOptions {
  std::string dir, calib, truth, out;
  std::vector<int> roi;
  double truth_sigma_cm = 0;
  double datum_cm = 0;
  bool mirror = false;
  int template_w = 64, template_h = 48, max_disparity = 256;
};

int RunRangeImages(const RangeImagesOptions& a) {
  const fitting::StereoRig rig = fitting::LoadStereoRig(a.calib);
  const fitting::Rectification rect = fitting::RectifyRig(rig);
  const auto truth = fitting::ReadRangeTruthCsv(a.truth);
  fitting::RangeOptions o;
  o.truth_sigma_m = a.truth_sigma_cm / 100;
  o.datum_offset_m = a.datum_cm / 100;
  o.match.template_width = a.template_w;
  o.match.template_height = a.template_h;
  o.match.max_disparity = a.max_disparity;
  // A template ROI must lie inside the left rectified image: refused, never clipped or moved.
  if (!a.roi.empty()) {
    if (a.roi.size() != 4) throw UsageError("--roi needs 4 numbers: x y w h");
    o.match.template_roi = cv::Rect(a.roi[0], a.roi[1], a.roi[2], a.roi[3]);
    if (!fitting::RoiInsideImage(o.match.template_roi, rect.size))
      throw UsageError("--roi " + std::to_string(a.roi[0]) + " " + std::to_string(a.roi[1]) + " " + std::to_string(a.roi[2]) +
                       " " + std::to_string(a.roi[3]) + " is not a template (w, h >= 5) inside the " +
                       std::to_string(rect.size.width) + "x" + std::to_string(rect.size.height) + " rectified image");
  }
  fitting::CheckRangeTruthRois(truth, rect.size);
  std::string why;
  if (!o.Check(&why)) throw UsageError(why);
  std::vector<fitting::RangeMeasurement> ms;
  for (const auto& t : truth) {
    fitting::RangeOptions ro = o;
    if (t.roi.area() > 0) ro.match.template_roi = t.roi;
    const std::string lp = (fs::path(a.dir) / t.left).string(), rp = (fs::path(a.dir) / t.right).string();
    cv::Mat l = cv::imread(lp), r = cv::imread(rp);
    if (l.empty()) throw std::runtime_error(lp + ": cannot read image");
    if (r.empty()) throw std::runtime_error(rp + ": cannot read image");
    if (a.mirror) {
      cv::flip(l, l, 1);
      cv::flip(r, r, 1);
    }
    fitting::RangeMeasurement m = fitting::RangePair(l, r, rig, rect, ro);
    m.name = t.left;
    m.true_m = t.distance_m;
    ms.push_back(m);
  }
  const fitting::RangeSummary s = fitting::SummariseRanges(ms);
  fs::create_directories(a.out);
  const fs::path out(a.out);
  std::string md = reports::RangeTableMarkdown(ms, s, "Range from stereo images: " + a.dir);
  md += "\nCalibration: " + rig.source + (rig.covariance.size() ? "" : " (no covariance: sigma is matching only)") +
        "; rectified f " + fitting::FixedOrDash(rect.focal_px, 2) + " px, baseline " +
        fitting::FixedOrDash(rect.baseline_m * 1000, 3) +
        " mm. Range = depth from the optical centres along the rectified axis + datum " +
        fitting::FixedOrDash(a.datum_cm, 1) + " cm; truth sigma " + fitting::FixedOrDash(a.truth_sigma_cm, 1) +
        " cm (the uncertainty of the true distances themselves: datum and placement).\n";
  std::ofstream(out / "ranges.md") << md;
  std::ofstream(out / "ranges.csv") << reports::RangeTableCsv(ms);
  reports::Figure f;
  f.name = "range_error";
  f.title = "Stereo range error vs true distance";
  f.xlabel = "true distance [cm]";
  f.ylabel = "error [%]";
  // The owlcal prediction (calibration + matching) as error bars; the uncertainty of the true
  // distances themselves as a grey band, so neither hides the other.
  reports::Series band;
  band.title = "true distance +-3 sigma";
  band.style = "filledcurves fs transparent solid 0.18 noborder lc rgb '#777777'";
  band.using_spec = "1:2:3";
  band.columns = {"true_cm", "lo_pct", "hi_pct"};
  reports::Series pts;
  pts.title = "measured, +-3 sigma predicted";
  pts.style = "yerrorbars pt 7 lc rgb '#1f77b4'";
  pts.using_spec = "1:2:3";
  pts.columns = {"true_cm", "err_pct", "three_sigma_pct"};
  for (const auto& m : ms)
    if (m.ok) {
      pts.rows.push_back({m.true_m * 100, 100 * m.error_m() / m.true_m, 300 * m.sigma_m / m.true_m});
      band.rows.push_back({m.true_m * 100, -300 * m.truth_sigma_m / m.true_m, 300 * m.truth_sigma_m / m.true_m});
    }
  if (a.truth_sigma_cm > 0) f.series.push_back(band);
  f.series.push_back(pts);
  f.settings.push_back("set xzeroaxis");
  const auto ff = reports::WriteFigure(f, a.out);
  if (!ff.drawn) std::cerr << "figure not drawn: " << ff.message << "\n";
  std::cout << md << "wrote " << a.out << ": ranges.md ranges.csv range_error.{csv,gp" << (ff.drawn ? ",png,svg" : "")
            << "}\n";
  return s.num_ranged == s.num_rows ? kExitOk : kExitFailed;
}

const bool kRegistered = RegisterCommand(
    "range-images",
    "Range a target in stereo pairs at known distances: rectify with a calibration (results.json,\n"
    "calibration.yaml or the course's intrinsics.xml + extrinsics.xml), match a template from the left\n"
    "image along the rectified row (NCC, sub-pixel), triangulate, and report error vs the truth CSV\n"
    "(left,right,distance_cm[,roi_x,roi_y,roi_w,roi_h]) with predicted sigma: ranges.md, ranges.csv, figure.",
    [](CLI::App* cmd) {
      auto o = std::make_shared<RangeImagesOptions>();
      cmd->add_option("dir", o->dir, "folder of the images named in the truth CSV")->required()->check(CLI::ExistingDirectory);
      cmd->add_option("--calib", o->calib, "calibration file or folder")->required();
      cmd->add_option("--truth", o->truth, "truth CSV")->required()->check(CLI::ExistingFile);
      cmd->add_option("--out", o->out, "output folder")->required();
      cmd->add_option("--roi", o->roi, "template x y w h in the left rectified image (default: central region)")
          ->expected(4);
      cmd->add_option("--template-size", o->template_w, "central template width [px]")->capture_default_str();
      cmd->add_option("--template-height", o->template_h, "central template height [px]")->capture_default_str();
      cmd->add_option("--max-disparity", o->max_disparity, "largest disparity searched [px]")->capture_default_str();
      cmd->add_option("--truth-sigma-cm", o->truth_sigma_cm, "uncertainty of the logged distances [cm]")
          ->capture_default_str();
      cmd->add_option("--datum-cm", o->datum_cm, "added to the depth from the optical centres [cm]")->capture_default_str();
      cmd->add_flag("--mirror", o->mirror, "flip each image horizontally first (mirrored captures)");
      return [o] { return RunRangeImages(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
