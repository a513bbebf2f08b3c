// The set verdict (evaluation/set_verdict.h) on the shared real sets: kit2020-chessboard, the
// three darvill2019 sessions (mirrored: calibrated with the flip) and OpenCV's sample keep
// `good`; a set made of only the small, central, fronto-parallel views of each gets `poor` (or
// worse), with advice on which views to add. The numbers are printed next to each other.
#include <algorithm>
#include <iostream>
#include <map>
#include <set>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "calib/image_pairs.h"
#include "evaluation/range_images_calib.h"
#include "reports/summary.h"
#include "reports/verdict_tables.h"
#include "tests/shared_data.h"

namespace owlcal::evaluation {
namespace set_verdict_real_test {

using ::owlcal::test_data::SharedData;

struct RealSet {
  std::string dir;
  bool mirror = false;
  double square = 0.026;
  std::string unit = "m";
  bool owl = true;
};

struct Loaded {
  calib::DetectedImageSet set;
  fitting::StereoFitOptions options;
  SetVerdictOptions verdict;
};

Loaded Load(const RealSet& s) {
  calib::TargetDefinition board;
  board.cols = 9;
  board.rows = 6;
  board.square_m = s.square;
  calib::ImagePairOptions po;
  po.mirror = s.mirror;
  calib::DetectorOptions det;
  det.fast_check = true;
  Loaded l;
  l.set = calib::DetectImagePairs(calib::ListImagePairs(SharedData() + "/" + s.dir, po), po, board, det);
  l.options.width = l.set.width;
  l.options.height = l.set.height;
  l.options.length_unit = s.unit;
  if (!s.owl) l.verdict.rig = RigExpectation::Generic();
  return l;
}

// Per paired frame: board area fraction (largest of the two eyes), centre offset (largest, as a
// fraction of the half-diagonal) and tilt (largest, from the full set's fit).
struct FrameShape {
  double area = 0, offset = 0, tilt = 0;
};

std::map<int, FrameShape> Shapes(const Loaded& l, const fitting::StereoFit& fit) {
  std::map<int, FrameShape> out;
  const double W = l.set.width, H = l.set.height, half_diag = std::hypot(W / 2, H / 2);
  for (const auto& v : calib::GroupIntoViews(l.set.observations)) {
    std::vector<cv::Point2f> pts;
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const auto& p : v.pixels) {
      pts.emplace_back(p.x(), p.y());
      mean += p / v.pixels.size();
    }
    std::vector<cv::Point2f> hull;
    cv::convexHull(pts, hull);
    FrameShape& s = out[v.frame_index];
    s.area = std::max(s.area, cv::contourArea(hull) / (W * H));
    s.offset = std::max(s.offset, (mean - Eigen::Vector2d((W - 1) / 2, (H - 1) / 2)).norm() / half_diag);
  }
  for (int e = 0; e < 2; ++e)
    for (const auto& [frame, tilt] : ViewTilts(fit, e))
      if (out.count(frame)) out[frame].tilt = std::max(out[frame].tilt, tilt);
  return out;
}

// The set's small, central, fronto-parallel views: board under 1/4 of the image, its centre
// within 30 % of the half-diagonal of the image centre, tilted less than 25 deg; the 6 most so
// (smallest area + offset + tilt / 90).
std::vector<calib::CornerObservation> PoorSubset(const Loaded& l, const fitting::StereoFit& fit, std::set<int>* kept) {
  const auto shapes = Shapes(l, fit);
  std::vector<std::pair<double, int>> passing;
  for (int f : fit.paired_frames) {
    const FrameShape& s = shapes.at(f);
    const double score = s.area + s.offset + s.tilt / 90;
    if (s.area < 0.25 && s.offset < 0.3 && s.tilt < 25) passing.push_back({score, f});
  }
  std::sort(passing.begin(), passing.end());
  for (size_t i = 0; i < passing.size() && kept->size() < 6; ++i) kept->insert(passing[i].second);
  std::cout << "  poor subset: " << passing.size() << " views pass (area < 0.25, offset < 0.3, tilt < 25 deg); kept";
  for (int f : *kept)
    std::cout << " " << f << " (area " << shapes.at(f).area << ", offset " << shapes.at(f).offset << ", tilt "
              << shapes.at(f).tilt << ")";
  std::cout << "\n";
  std::vector<calib::CornerObservation> obs;
  for (const auto& o : l.set.observations)
    if (kept->count(o.frame_index)) obs.push_back(o);
  return obs;
}

// expect_poor: the subset has enough distinct views to be calibrated (then exactly "poor",
// with the focal length refused); otherwise anything but "good".
void CheckSet(const RealSet& s, int min_pairs, bool expect_poor = true) {
  const Loaded l = Load(s);
  const ImageSetCalibration c = CalibrateImageSet(l.set.observations, l.options, l.verdict);
  ASSERT_TRUE(c.fit.ok) << s.dir << ": " << c.fit.message;
  std::cout << s.dir << ": " << c.fit.paired_frames.size() << " pairs, joint RMS " << c.fit.rms_joint_px << " px\n"
            << reports::SetVerdictMarkdown(c.set_verdict);
  EXPECT_GE(static_cast<int>(c.fit.paired_frames.size()), min_pairs);
  EXPECT_EQ(c.set_verdict.status, "good") << s.dir;
  EXPECT_TRUE(c.set_verdict.reasons.empty());
  EXPECT_TRUE(c.set_verdict.split) << c.set_verdict.split_message;
  ASSERT_FALSE(c.result.verdict.is_null());
  EXPECT_EQ(c.result.verdict.at("status"), "good");
  // The trusted region is what the verdict judged, and the report's summary quotes it: a good set
  // is trusted over (at least) 90 % of its working region, and the summary says no less.
  reports::ReportData rd;
  rd.result = c.result;
  const reports::Summary summary = reports::MakeSummary(rd);
  for (int e = 0; e < 2; ++e) {
    const EyeVerdictMetrics& m = c.set_verdict.eye[e];
    EXPECT_GE(m.trusted_working_fraction, 0.9) << s.dir << " eye " << e;
    const auto& tr = c.result.verdict.at("metrics").at("eyes").at(e == 0 ? "left" : "right").at("trusted_region");
    EXPECT_DOUBLE_EQ(tr.at("working_fraction").get<double>(), m.trusted_working_fraction);
    EXPECT_DOUBLE_EQ(tr.at("fraction").get<double>(), m.trusted_fraction);
  }
  for (const auto& step : summary.next_steps) {
    EXPECT_EQ(step.find("valid-intrinsics region"), std::string::npos) << step;
    if (step.find("trusted over") != std::string::npos) {
      EXPECT_NE(step.find("set verdict's trusted region"), std::string::npos) << step;
    }
  }

  std::set<int> kept;
  const auto flat = PoorSubset(l, c.fit, &kept);
  const ImageSetCalibration p = CalibrateImageSet(flat, l.options, l.verdict);
  std::cout << "  " << reports::SetVerdictMarkdown(p.set_verdict);
  EXPECT_NE(p.set_verdict.status, "good") << s.dir << " poor subset";
  EXPECT_FALSE(p.set_verdict.reasons.empty());
  EXPECT_FALSE(p.set_verdict.advice.empty());
  if (expect_poor) {
    EXPECT_EQ(p.set_verdict.status, "poor") << s.dir;
    // The trusted region alone already says so (ratio sigma / noise 19-126 against 10).
    for (int e = 0; e < 2; ++e) EXPECT_LT(p.set_verdict.eye[e].trusted_working_fraction, 0.9) << s.dir << " eye " << e;
    bool tilt = false;
    for (const auto& a : p.set_verdict.advice) tilt |= a.find("tilt the board") != std::string::npos;
    EXPECT_TRUE(tilt) << "no tilt advice for a set of flat views";
    const fitting::Parameter* fx = p.result.Find("left.fx");
    ASSERT_NE(fx, nullptr);
    EXPECT_FALSE(fx->determined) << "a poor set's focal length is refused";
  }
  EXPECT_EQ(p.result.verdict.at("status"), p.set_verdict.status);
}

TEST(SetVerdictReal, Kit2020IsGoodAndItsFlatCentralViewsArePoor) { CheckSet({"owl-real/kit2020-chessboard"}, 27); }

TEST(SetVerdictReal, Darvill2019Session1IsGoodAndItsFlatCentralViewsArePoor) {
  CheckSet({"owl-real/darvill2019-chessboard/session1", true}, 10);
}

TEST(SetVerdictReal, Darvill2019Session2IsGoodAndItsFlatCentralViewsArePoor) {
  CheckSet({"owl-real/darvill2019-chessboard/session2", true}, 10);
}

TEST(SetVerdictReal, Darvill2019Session3IsGoodAndItsFlatCentralViewsArePoor) {
  CheckSet({"owl-real/darvill2019-chessboard/session3", true}, 10);
}

TEST(SetVerdictReal, OpenCvSampleIsGoodAndItsFlatCentralViewsArePoor) {
  // Only one of its views is small, central and flat: that "set" cannot be calibrated at all.
  CheckSet({"opencv-stereo-chessboard", false, 1.0, "square", false}, 13, /*expect_poor=*/false);
}

}  // namespace set_verdict_real_test
}  // namespace owlcal::evaluation
