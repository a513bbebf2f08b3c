// Intrinsics fit: the OpenCV sample set (real images) and synthetic degenerate inputs.
#include "fitting/intrinsics_fit.h"

#include <cstdlib>
#include <filesystem>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/detector.h"
#include "owlcal_version.h"
#include "tests/shared_data.h"

namespace owlcal::fitting {
namespace {

using ::owlcal::test_data::SharedData;

calib::TargetDefinition OpenCvBoard() {
  calib::TargetDefinition t;
  t.id = "opencv-sample";
  t.cols = 9;
  t.rows = 6;
  t.square_m = 1.0;
  return t;
}

// Views of one eye of the OpenCV stereo set, detected with the default (5x5 window) detector.
std::vector<calib::View> OpenCvViews(const std::string& eye_prefix, int eye) {
  const std::string dir = SharedData() + "/opencv-stereo-chessboard";
  std::vector<calib::CornerObservation> obs;
  for (int i : {1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 12, 13, 14}) {
    char name[32];
    std::snprintf(name, sizeof(name), "%s%02d.jpg", eye_prefix.c_str(), i);
    const cv::Mat img = cv::imread(dir + "/" + name, cv::IMREAD_GRAYSCALE);
    if (img.empty()) continue;
    const auto det = calib::DetectTarget(img, OpenCvBoard(), calib::DetectorOptions());
    const auto o = calib::DetectionToObservations(det, OpenCvBoard(), i, eye);
    obs.insert(obs.end(), o.begin(), o.end());
  }
  return calib::GroupIntoViews(obs);
}

TEST(FitIntrinsics, OpenCvSampleLeftMatchesOpenCvAndMrcal) {
  const auto views = OpenCvViews("left", 0);
  ASSERT_EQ(views.size(), 13u) << "shared data missing? " << SharedData();
  const IntrinsicsFit fit = FitIntrinsics(views, 640, 480, IntrinsicsFitOptions());
  ASSERT_TRUE(fit.ok) << fit.message;
  EXPECT_LE(fit.rms_px, 0.21);
  EXPECT_NEAR(fit.camera.params[0], 533.0, 3.0);
  EXPECT_NEAR(fit.camera.params[1], 533.0, 3.0);
  EXPECT_NEAR(fit.camera.params[2], 342.5, 3.0);
  EXPECT_NEAR(fit.camera.params[3], 234.0, 3.0);
  EXPECT_TRUE(fit.determined[0] && fit.determined[1] && fit.determined[2] && fit.determined[3]);
  EXPECT_GT(fit.sigmas[0], 0.01);
  EXPECT_LT(fit.sigmas[0], 5.0);
  EXPECT_NEAR(fit.corner_sigma_px, fit.rms_px / std::sqrt(2.0), 0.05);
  EXPECT_EQ(fit.view_rms_px.size(), 13u);
  for (size_t i = 0; i < fit.param_names.size(); ++i)
    std::printf("%s = %.4f +- %.4f\n", fit.param_names[i].c_str(), fit.camera.params[i], fit.sigmas[i]);
  std::printf("rms %.4f sigma %.4f %s\n", fit.rms_px, fit.corner_sigma_px, fit.message.c_str());
  for (auto& u : fit.undetermined) std::printf("undetermined %s\n", u.c_str());
}

TEST(FitIntrinsics, OpenCvSampleRightRmsWithinBound) {
  const auto views = OpenCvViews("right", 1);
  ASSERT_EQ(views.size(), 13u);
  const IntrinsicsFit fit = FitIntrinsics(views, 640, 480, IntrinsicsFitOptions());
  ASSERT_TRUE(fit.ok) << fit.message;
  EXPECT_LE(fit.rms_px, 0.21);
  std::printf("right rms %.4f fx %.3f\n", fit.rms_px, fit.camera.params[0]);
}

}  // namespace
}  // namespace owlcal::fitting
