// Acceptance on the course's kit2020 sets: stereo calibration from
// kit2020-chessboard against cv::stereoCalibrate and the students' numbers, ranging of
// kit2020-distance-target1 with that calibration, and the poor-set verdict.
#include <cstdlib>
#include <iostream>
#include <map>
#include <set>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/image_pairs.h"
#include "evaluation/range_images_calib.h"
#include "evaluation/range_images_ranging.h"
#include "evaluation/reference_comparison.h"
#include "owlcal_version.h"
#include "reports/image_set_tables.h"
#include "tests/shared_data.h"

namespace owlcal::fitting {
namespace real_kit2020_test {

using ::owlcal::test_data::SharedData;

calib::TargetDefinition KitBoard() {
  calib::TargetDefinition t;
  t.id = "owl-kit";
  t.cols = 9;
  t.rows = 6;
  t.square_m = 0.026;
  return t;
}

constexpr double kMaxFlatTiltDeg = 15;

// Detection once for every test in this file.
const calib::DetectedImageSet& KitCorners() {
  static const calib::DetectedImageSet set = [] {
    const std::string dir = SharedData() + "/owl-real/kit2020-chessboard";
    const auto list = calib::ListImagePairs(dir, {});
    return calib::DetectImagePairs(list, {}, KitBoard(), {});
  }();
  return set;
}

StereoFitOptions KitOptions() {
  StereoFitOptions o;
  o.width = 640;
  o.height = 480;
  return o;
}

const evaluation::ImageSetCalibration& KitCalibration() {
  static const evaluation::ImageSetCalibration c =
      evaluation::CalibrateImageSet(KitCorners().observations, KitOptions());
  return c;
}

const Parameter& Get(const CalibrationResult& r, const std::string& name) {
  const Parameter* p = r.Find(name);
  if (!p) throw std::runtime_error("parameter " + name + " missing");
  return *p;
}

TEST(RealKit2020, StereoRmsBeatsOpenCvOnSameCornersAndTheStudents) {
  const auto& set = KitCorners();
  int found = 0;
  for (const auto& p : set.pairs) found += p.found[0] + p.found[1];
  EXPECT_EQ(found, 54);
  const evaluation::ImageSetCalibration& c = KitCalibration();
  ASSERT_TRUE(c.fit.ok) << c.fit.message;

  // cv::stereoCalibrate on exactly the same corners, same 5-coefficient model, all free.
  std::map<int, std::vector<cv::Point2f>> px[2];
  std::map<int, std::vector<cv::Point3f>> obj;
  for (const auto& o : set.observations) {
    px[o.eye][o.frame_index].push_back(cv::Point2f(o.pixel.x(), o.pixel.y()));
    if (o.eye == 0)
      obj[o.frame_index].push_back(cv::Point3f(o.point_in_target.x(), o.point_in_target.y(), o.point_in_target.z()));
  }
  std::vector<std::vector<cv::Point2f>> il, ir;
  std::vector<std::vector<cv::Point3f>> io;
  for (const auto& [f, pts] : obj) {
    if (!px[1].count(f) || px[1][f].size() != pts.size()) continue;
    il.push_back(px[0][f]);
    ir.push_back(px[1][f]);
    io.push_back(pts);
  }
  const cv::Size size(640, 480);
  cv::Mat K1, D1, K2, D2, R, T, E, F, rv, tv;
  cv::calibrateCamera(io, il, size, K1, D1, rv, tv);
  cv::calibrateCamera(io, ir, size, K2, D2, rv, tv);
  const double cv_rms =
      cv::stereoCalibrate(io,
                          il,
                          ir,
                          K1,
                          D1,
                          K2,
                          D2,
                          size,
                          R,
                          T,
                          E,
                          F,
                          cv::CALIB_USE_INTRINSIC_GUESS,
                          cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-10));
  std::cout << "kit2020-chessboard, " << il.size() << " pairs: owlcal joint RMS " << c.fit.rms_joint_px << " px (left "
            << c.fit.rms_px[0] << ", right " << c.fit.rms_px[1] << "), cv::stereoCalibrate RMS " << cv_rms
            << " px; students 0.826912 px\n"
            << "rectified |dy| mean " << c.fit.rectified_dy_mean_px << " px, max " << c.fit.rectified_dy_max_px
            << " px; students' average epipolar error 1.24223 px\n"
            << "owlcal T = " << c.fit.right_from_left.translation.transpose() * 1000
            << " mm; OpenCV T = " << T.t() * 1000 << " mm\n";
  EXPECT_LE(c.fit.rms_joint_px, cv_rms + 1e-3);
  EXPECT_LT(c.fit.rms_joint_px, 0.826912);
  EXPECT_LT(c.fit.rectified_dy_mean_px, 1.24223);
  for (const char* n : {"left.fx", "left.cx", "right.fx", "stereo.baseline_mm", "stereo.tx_mm"}) {
    const Parameter* p = c.result.Find(n);
    if (!p) continue;
    EXPECT_TRUE(p->determined) << n;
    EXPECT_TRUE(std::isfinite(p->sigma) && p->sigma > 0) << n;
  }
  const Parameter& b = Get(c.result, "stereo.baseline_mm");
  std::cout << "baseline " << b.value << " +- " << b.sigma << " mm; left.fx " << Get(c.result, "left.fx").value
            << " +- " << Get(c.result, "left.fx").sigma << " px\n";
  EXPECT_NEAR(b.value, 64.1, 1.5);
  EXPECT_TRUE(c.verdict.empty()) << c.verdict.front();
}

// Issue 11 item 3: how much of the difference from the course's reference calibration the lens
// model explains. The difference splits into corner detection, model, estimator and board bow
// (evaluation/reference_comparison.h); the parts add up, owlcal's flat fit is OpenCV's with the same
// model (estimator part ~0), and the course program rerun on owlcal's corners fits them better
// than the course's own corners (its RMS 0.8269).
TEST(RealKit2020, ReferenceDifferenceSplitsIntoDetectionModelAndBow) {
  const std::vector<calib::View> views = calib::GroupIntoViews(KitCorners().observations);
  std::vector<calib::View> eye[2];
  for (const auto& v : views) eye[v.eye].push_back(v);
  StereoFitOptions o = KitOptions();
  const StereoFit flat = FitStereo(eye[0], eye[1], o);
  o.fit_board_warp = true;
  const StereoFit bowed = FitStereo(eye[0], eye[1], o);
  ASSERT_TRUE(flat.ok && bowed.ok);
  const std::string ref = SharedData() + "/owl-real/kit2020-chessboard/reference/";
  const OpenCvStereoCalibration reference = ReadOpenCvSplitFiles(ref + "intrinsics.xml", ref + "extrinsics.xml");
  const evaluation::ReferenceComparison c =
      evaluation::CompareWithReference(eye[0], eye[1], bowed, &flat, reference, {});
  ASSERT_TRUE(c.ok) << c.message;
  std::cout << evaluation::ReferenceComparisonMarkdown(c);
  EXPECT_EQ(c.num_pairs, 27);
  EXPECT_EQ(c.rows.size(), 15u);
  EXPECT_LT(c.rms_reference_model_px, 0.826912);
  for (const auto& r : c.rows) {
    EXPECT_NEAR(r.Detection() + r.Model() + r.Estimator() + r.Bow(), r.Total(), 1e-9) << r.name;
    // Same corners, same model, flat board: owlcal's estimate is OpenCV's (within a tenth of sigma).
    if (r.owlcal_sigma > 0) {
      EXPECT_LT(std::abs(r.Estimator()), 0.1 * r.owlcal_sigma) << r.name;
    }
    // The two corner finders agree on this set: the course program on either's corners is the same
    // calibration within owlcal's sigma.
    if (r.owlcal_sigma > 0) {
      EXPECT_LT(std::abs(r.Detection()), r.owlcal_sigma) << r.name;
    }
  }
  EXPECT_NEAR(c.share_detection + c.share_model + c.share_estimator + c.share_bow, 1.0, 1e-9);
  // Measured: the model 19 %, the bow 75 %, detection 7 %: the bow, not the model, explains most.
  EXPECT_GT(c.share_model, 0.1);
  EXPECT_LT(c.share_model, 0.3);
  EXPECT_GT(c.share_bow, 0.5);
  EXPECT_NE(c.message.find("lens-model choice (opencv5) explains"), std::string::npos) << c.message;

  // The reference's program on the same corners: nothing is left for the detection part.
  std::map<int, const calib::View*> right;
  for (const auto& v : eye[1]) right[v.frame_index] = &v;
  std::vector<std::vector<cv::Point3f>> obj;
  std::vector<std::vector<cv::Point2f>> px[2];
  for (const auto& l : eye[0]) {
    if (!right.count(l.frame_index)) continue;
    std::vector<cv::Point3f> op;
    std::vector<cv::Point2f> p0, p1;
    for (size_t i = 0; i < l.corner_ids.size(); ++i) {
      op.emplace_back(float(l.points_in_target[i].x()), float(l.points_in_target[i].y()), 0.f);
      p0.emplace_back(float(l.pixels[i].x()), float(l.pixels[i].y()));
      p1.emplace_back(float(right[l.frame_index]->pixels[i].x()), float(right[l.frame_index]->pixels[i].y()));
    }
    obj.push_back(op);
    px[0].push_back(p0);
    px[1].push_back(p1);
  }
  OpenCvStereoCalibration same;
  same.length_unit = "m";
  same.M1 = cv::initCameraMatrix2D(obj, px[0], cv::Size(640, 480), 0);
  same.M2 = cv::initCameraMatrix2D(obj, px[1], cv::Size(640, 480), 0);
  same.D1 = cv::Mat::zeros(1, 8, CV_64F);
  same.D2 = cv::Mat::zeros(1, 8, CV_64F);
  cv::Mat e, f;
  cv::stereoCalibrate(obj,
                      px[0],
                      px[1],
                      same.M1,
                      same.D1,
                      same.M2,
                      same.D2,
                      cv::Size(640, 480),
                      same.R,
                      same.T,
                      e,
                      f,
                      cv::CALIB_FIX_ASPECT_RATIO | cv::CALIB_ZERO_TANGENT_DIST | cv::CALIB_USE_INTRINSIC_GUESS |
                          cv::CALIB_SAME_FOCAL_LENGTH | cv::CALIB_RATIONAL_MODEL | cv::CALIB_FIX_K3 | cv::CALIB_FIX_K4 |
                          cv::CALIB_FIX_K5,
                      cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-5));
  const evaluation::ReferenceComparison s = evaluation::CompareWithReference(eye[0], eye[1], bowed, &flat, same, {});
  ASSERT_TRUE(s.ok) << s.message;
  for (const auto& r : s.rows) EXPECT_NEAR(r.Detection(), 0.0, 1e-6 * std::max(1.0, std::abs(r.reference))) << r.name;
}

TEST(RealKit2020, DistanceTargetRangedWithin3PercentAndThreeSigma) {
  const evaluation::ImageSetCalibration& c = KitCalibration();
  ASSERT_TRUE(c.fit.ok) << c.fit.message;
  const StereoRig rig = RigFromStereoFit(c.fit, 1.0);
  ASSERT_EQ(rig.covariance.rows(), rig.NumParams());
  const Rectification rect = RectifyRig(rig);
  const std::string dir = SharedData() + "/owl-real/kit2020-distance-target1";
  const auto truth =
      evaluation::ReadRangeTruthCsv(std::string(OWLCAL_SOURCE_DIR) + "/data/real/kit2020_distance_target1.csv");
  ASSERT_EQ(truth.size(), 13u);
  evaluation::RangeOptions o;
  // The truth is a box held by hand over a ruler from an unknown datum (README): 2 cm.
  o.truth_sigma_m = 0.02;
  std::vector<evaluation::RangeMeasurement> ms;
  for (const auto& t : truth) {
    o.match.template_roi = t.roi;
    const cv::Mat l = cv::imread(dir + "/" + t.left), r = cv::imread(dir + "/" + t.right);
    ASSERT_FALSE(l.empty() || r.empty()) << t.left;
    evaluation::RangeMeasurement m = evaluation::RangePair(l, r, rig, rect, o);
    m.name = t.left;
    m.true_m = t.distance_m;
    ms.push_back(m);
  }
  const evaluation::RangeSummary s = evaluation::SummariseRanges(ms, 0.30, 1.50);
  std::cout << reports::RangeTableMarkdown(
      ms, s, "kit2020-distance-target1 ranged with owlcal's kit2020-chessboard calibration");
  EXPECT_EQ(s.num_ranged, 13);
  EXPECT_LE(s.mean_abs_rel, 0.03);
  EXPECT_EQ(s.num_outside_3sigma, 0);
}

TEST(RealKit2020, SetWithoutTiltedViewsSaysFocalLengthIsUndetermined) {
  const evaluation::ImageSetCalibration& full = KitCalibration();
  ASSERT_TRUE(full.fit.ok);
  std::map<int, double> tilt;
  for (int e = 0; e < 2; ++e)
    for (const auto& [frame, t] : evaluation::ViewTilts(full.fit, e)) tilt[frame] = std::max(tilt[frame], t);
  std::vector<calib::CornerObservation> flat;
  std::set<int> kept;
  for (const auto& o : KitCorners().observations) {
    if (tilt.count(o.frame_index) && tilt[o.frame_index] < kMaxFlatTiltDeg) {
      flat.push_back(o);
      kept.insert(o.frame_index);
    }
  }
  std::cout << "tilts (deg):";
  for (const auto& [f, t] : tilt) std::cout << " " << f << ":" << t;
  std::cout << "\nkept " << kept.size() << " untilted pairs\n";
  ASSERT_GE(kept.size(), 3u);
  const evaluation::ImageSetCalibration poor = evaluation::CalibrateImageSet(flat, KitOptions());
  std::cout << reports::ImageSetReportMarkdown(poor, {});
  EXPECT_TRUE(poor.poor);
  ASSERT_FALSE(poor.verdict.empty());
  bool names_focal = false;
  for (const auto& v : poor.verdict) names_focal |= v.find("focal length") != std::string::npos;
  EXPECT_TRUE(names_focal);
  for (const char* n : {"left.fx", "left.fy", "right.fx", "left.cx"}) {
    const Parameter* p = poor.result.Find(n);
    if (!p) continue;  // absent is as honest as undetermined
    EXPECT_FALSE(p->determined) << n;
    EXPECT_TRUE(std::isnan(p->sigma)) << n << " sigma " << p->sigma;
  }
}

}  // namespace real_kit2020_test
}  // namespace owlcal::fitting
