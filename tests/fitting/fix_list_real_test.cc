// Held parameters (fitting/fix_list.h, calibrate-images --fix) on OpenCV's stereo sample: with
// k3 held the fit has k3 exactly 0 and agrees with cv::calibrateCamera(CALIB_FIX_K3) on the
// same corners; every item of the list holds what OpenCV's flag holds; results.json marks the
// held parameters (held, sigma 0, not determined) and the verdict does not count them against
// the set.
#include <cmath>
#include <iostream>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "calib/image_pairs.h"
#include "evaluation/range_images_calib.h"
#include "fitting/fix_list.h"
#include "fitting/intrinsics_fit.h"
#include "tests/shared_data.h"

namespace owlcal::fitting {
namespace {

using ::owlcal::test_data::SharedData;

calib::DetectedImageSet OpenCvSample() {
  calib::TargetDefinition board;
  board.cols = 9;
  board.rows = 6;
  board.square_m = 1.0;
  const auto list = calib::ListImagePairs(SharedData() + "/opencv-stereo-chessboard", {});
  return calib::DetectImagePairs(list, {}, board, calib::DetectorOptions());
}

std::vector<calib::View> EyeViews(const calib::DetectedImageSet& set, int eye) {
  std::vector<calib::View> out;
  for (const auto& v : calib::GroupIntoViews(set.observations))
    if (v.eye == eye) out.push_back(v);
  return out;
}

TEST(FixListReal, HeldK3IsExactlyZeroAndTheRestMatchesOpenCv) {
  const calib::DetectedImageSet set = OpenCvSample();
  const std::vector<calib::View> views = EyeViews(set, 0);
  ASSERT_GE(views.size(), 10u);
  IntrinsicsFitOptions o;
  o.outlier_threshold_sigma = 0;  // the same corners as OpenCV's (it rejects none)
  std::string why;
  ASSERT_TRUE(ApplyFixList("k3", &o, &why)) << why;
  const IntrinsicsFit f = FitIntrinsics(views, set.width, set.height, o);
  ASSERT_TRUE(f.ok) << f.message;
  EXPECT_EQ(f.camera.params[8], 0.0);  // k3, exactly

  std::vector<std::vector<cv::Point3f>> object;
  std::vector<std::vector<cv::Point2f>> image;
  for (const auto& v : views) {
    object.emplace_back();
    image.emplace_back();
    for (size_t i = 0; i < v.pixels.size(); ++i) {
      object.back().emplace_back(v.points_in_target[i].x(), v.points_in_target[i].y(), v.points_in_target[i].z());
      image.back().emplace_back(v.pixels[i].x(), v.pixels[i].y());
    }
  }
  cv::Mat K, D;
  std::vector<cv::Mat> rvecs, tvecs;
  const double rms = cv::calibrateCamera(object,
                                         image,
                                         cv::Size(set.width, set.height),
                                         K,
                                         D,
                                         rvecs,
                                         tvecs,
                                         cv::CALIB_FIX_K3,
                                         cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-12));
  std::cout << "owlcal: RMS " << f.rms_px << " px, fx " << f.camera.params[0] << ", k1 " << f.camera.params[4]
            << "; OpenCV CALIB_FIX_K3: RMS " << rms << " px, fx " << K.at<double>(0, 0) << ", k1 " << D.at<double>(0)
            << "\n";
  EXPECT_EQ(D.at<double>(4), 0.0);
  EXPECT_NEAR(f.rms_px, rms, 1e-3);
  const double opencv[8] = {K.at<double>(0, 0),
                            K.at<double>(1, 1),
                            K.at<double>(0, 2),
                            K.at<double>(1, 2),
                            D.at<double>(0),
                            D.at<double>(1),
                            D.at<double>(2),
                            D.at<double>(3)};
  const int index[8] = {0, 1, 2, 3, 4, 5, 6, 7};
  for (int i = 0; i < 8; ++i) {
    const double sigma = f.sigmas[index[i]];
    ASSERT_TRUE(std::isfinite(sigma)) << f.param_names[index[i]];
    EXPECT_LT(std::abs(f.camera.params[index[i]] - opencv[i]), 0.05 * sigma)
        << f.param_names[index[i]] << ": owlcal " << f.camera.params[index[i]] << ", OpenCV " << opencv[i] << ", sigma "
        << sigma;
  }
}

TEST(FixListReal, EveryItemHoldsWhatOpenCvsFlagHolds) {
  const calib::DetectedImageSet set = OpenCvSample();
  const std::vector<calib::View> views = EyeViews(set, 0);
  IntrinsicsFitOptions o;
  o.model = models::DistortionModel::kOpenCv8;
  std::string why;
  ASSERT_TRUE(ApplyFixList("k1,k2,k4,k5,k6,principal_point,fx=fy,tangential", &o, &why)) << why;
  const std::vector<std::string> expect = {
      "k1", "k2", "k4", "k5", "k6", "principal_point", "aspect_ratio", "tangential"};
  EXPECT_EQ(FixListOf(o), expect);
  const IntrinsicsFit f = FitIntrinsics(views, set.width, set.height, o);
  ASSERT_TRUE(f.ok) << f.message;
  const auto& p = f.camera.params;  // fx fy cx cy k1 k2 p1 p2 k3 k4 k5 k6
  EXPECT_EQ(p[1], p[0]);
  EXPECT_EQ(p[2], (set.width - 1) / 2.0);
  EXPECT_EQ(p[3], (set.height - 1) / 2.0);
  for (int i : {4, 5, 6, 7, 9, 10, 11}) EXPECT_EQ(p[i], 0.0) << f.param_names[i];
  EXPECT_NE(p[8], 0.0);  // k3 alone floats
  for (const char* bad : {"k7", "k3,,k2", "principal", "K3"}) {
    IntrinsicsFitOptions b;
    EXPECT_FALSE(ApplyFixList(bad, &b, &why)) << bad;
    EXPECT_NE(why.find("--fix"), std::string::npos) << why;
  }
}

TEST(FixListReal, ResultsMarkHeldParametersAndTheVerdictDoesNotCountThem) {
  const calib::DetectedImageSet set = OpenCvSample();
  StereoFitOptions o;
  o.width = set.width;
  o.height = set.height;
  o.length_unit = "square";
  std::string why;
  ASSERT_TRUE(ApplyFixList("k3", &o.intrinsics, &why)) << why;
  evaluation::SetVerdictOptions vo;
  vo.rig = evaluation::RigExpectation::Generic();
  const evaluation::ImageSetCalibration c = evaluation::CalibrateImageSet(set.observations, o, vo);
  ASSERT_TRUE(c.fit.ok) << c.fit.message;
  for (const char* name : {"left.k3", "right.k3"}) {
    const Parameter* p = c.result.Find(name);
    ASSERT_NE(p, nullptr) << name;
    EXPECT_EQ(p->value, 0.0) << name;
    EXPECT_TRUE(p->held) << name;
    EXPECT_EQ(p->sigma, 0.0) << name;
    EXPECT_FALSE(p->determined) << name;
  }
  EXPECT_FALSE(c.result.Find("left.k2")->held);
  const nlohmann::json j = ToJson(c.result);
  bool marked = false;
  for (const auto& p : j.at("parameters"))
    if (p.at("name") == "left.k3") marked = p.value("held", false);
  EXPECT_TRUE(marked);
  for (const auto& r : c.set_verdict.reasons) EXPECT_EQ(r.find("k3"), std::string::npos) << r;
}

}  // namespace
}  // namespace owlcal::fitting
