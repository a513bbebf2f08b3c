// Dense SGBM depth against the virtual Owl's truth depth image: textured targets (a textured
// wall, an AprilGrid board in front of the wall) at 0.3-1.5 m, rendered with the stream's
// noise and JPEG, rectified with the true stereo calibration; the depth at the target must be
// within 2 % of the renderer's truth, and most of the ROI's pixels too.
#include "evaluation/stereo_depth.h"

#include <cmath>
#include <cstdio>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "sim/renderer.h"
#include "sim/virtual_owl.h"

namespace owlcal::evaluation {
namespace {

struct Case {
  double depth_m;  // of the target's plane from the left camera
  bool board;      // AprilGrid in front of the wall at 3 m; else the wall itself at that depth
};

// The truth rig at the pose `a`: the renderer's cameras and right_from_left between them.
fitting::StereoRig TruthRig(const sim::VirtualOwl& owl, const models::JointAngles& a) {
  fitting::StereoRig rig;
  rig.cameras[0] = owl.Truth().intrinsics[0];
  rig.cameras[1] = owl.Truth().intrinsics[1];
  rig.right_from_left = owl.CamFromBase(models::kRightEye, a) * owl.CamFromBase(models::kLeftEye, a).Inverse();
  rig.source = "virtual Owl truth";
  return rig;
}

// What the stream delivers: sensor noise, then JPEG at the stream's quality.
cv::Mat AsStreamed(cv::Mat grey, const sim::VirtualOwl& owl, uint64_t stream) {
  sim::AddSensorNoise(&grey, owl.Truth().stream.noise_sigma, 11, stream);
  std::vector<uint8_t> jpeg;
  cv::imencode(".jpg", grey, jpeg, {cv::IMWRITE_JPEG_QUALITY, owl.Truth().stream.jpeg_quality});
  return cv::imdecode(jpeg, cv::IMREAD_GRAYSCALE);
}

double MedianOf(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

TEST(StereoDepth, SgbmWithinTwoPercentOfRendererTruthOnTexturedTargets) {
  const std::vector<Case> cases = {{0.3, false},
                                   {0.5, false},
                                   {0.8, false},
                                   {1.1, false},
                                   {1.5, false},
                                   {0.3, true},
                                   {0.5, true},
                                   {0.8, true},
                                   {1.1, true},
                                   {1.5, true}};
  const models::JointAngles a;  // eyes and neck at zero: looking ahead
  // The left camera's centre sits a few cm ahead of the neck axis (the base frame's origin).
  const double cam_z_in_base = sim::VirtualOwl({}).CamFromBase(models::kLeftEye, a).Inverse().translation.z();
  for (const Case& c : cases) {
    SCOPED_TRACE(std::string(c.board ? "AprilGrid at " : "textured wall at ") + std::to_string(c.depth_m) + " m");
    const double distance_m = c.depth_m + cam_z_in_base;
    sim::SceneDescription scene;
    if (c.board) {
      sim::SceneTarget grid;
      grid.definition.id = "grid";
      grid.definition.kind = calib::TargetKind::kAprilGrid;
      grid.base_from_target = sim::FacingPose(grid.definition, {0.0, 0.0, distance_m});
      scene.targets.push_back(grid);
    } else {
      // The wall's texture scaled with its distance, so its image detail stays the same.
      scene.background.distance_m = distance_m;
      scene.background.texel_m = 0.004 * distance_m / 3.0;
    }
    sim::VirtualOwlOptions o;
    o.scene = scene;
    const sim::VirtualOwl owl(o);
    cv::Mat truth_raw;
    const cv::Mat left = AsStreamed(owl.RenderEyeGrey(models::kLeftEye, a, &truth_raw), owl, 0);
    const cv::Mat right = AsStreamed(owl.RenderEyeGrey(models::kRightEye, a), owl, 1);
    const fitting::StereoRig rig = TruthRig(owl, a);
    DepthOptions opt;
    const fitting::Rectification rect = fitting::RectifyRig(rig, opt.rectify_alpha);
    const DepthMaps maps = ComputeDepth(left, right, rect, opt);
    const cv::Mat truth = RectifyTruthDepth(rect, truth_raw);

    // ROI: 40 x 30 px around the image of the target's centre (the wall: the image centre).
    cv::Point2d centre(rect.P1(0, 2), rect.P1(1, 2));
    if (c.board) {
      const Eigen::Vector4d e = scene.targets[0].definition.Extent();
      const Eigen::Vector3d centre_in_base =
          scene.targets[0].base_from_target * Eigen::Vector3d((e[0] + e[1]) / 2, (e[2] + e[3]) / 2, 0);
      const Eigen::Vector3d in_cam = owl.CamFromBase(models::kLeftEye, a) * centre_in_base;
      const cv::Vec3d in_rect = rect.R1 * cv::Vec3d(in_cam.x(), in_cam.y(), in_cam.z());
      centre = {rect.P1(0, 0) * in_rect[0] / in_rect[2] + rect.P1(0, 2),
                rect.P1(1, 1) * in_rect[1] / in_rect[2] + rect.P1(1, 2)};
    }
    const cv::Rect roi(int(centre.x) - 20, int(centre.y) - 15, 40, 30);
    const RoiDepth d = DepthAtRoi(maps, roi, rig, rect, opt);
    ASSERT_TRUE(d.ok) << d.message;
    std::vector<double> t;
    int within = 0, valid = 0;
    for (int y = roi.y; y < roi.y + roi.height; ++y)
      for (int x = roi.x; x < roi.x + roi.width; ++x) {
        const float z = truth.at<float>(y, x), m = maps.depth_m.at<float>(y, x);
        ASSERT_TRUE(std::isfinite(z));
        t.push_back(z);
        if (!std::isfinite(m)) continue;
        ++valid;
        within += std::abs(m - z) < 0.02 * z;
      }
    const double true_z = MedianOf(t);
    // The renderer's truth itself: the target's plane is where the scene puts it.
    EXPECT_NEAR(true_z, c.depth_m, 0.003);
    const double err = (d.depth_m - true_z) / true_z;
    EXPECT_LT(std::abs(err), 0.02) << "depth " << d.depth_m << " m, truth " << true_z << " m";
    std::printf("%-9s %.2f m: truth %.4f m, SGBM %.4f +- %.4f m (%+.2f %%), %.0f %% of ROI pixels within 2 %%\n",
                c.board ? "AprilGrid" : "wall",
                c.depth_m,
                true_z,
                d.depth_m,
                d.sigma_m,
                100 * err,
                100.0 * within / valid);
    EXPECT_GT(d.valid_fraction(), 0.9);
    EXPECT_GT(double(within) / valid, 0.9) << "pixels within 2 %: " << within << " of " << valid;
    // The predicted sigma is not a license: the error is within 4 sigma plus the 0.1 px floor.
    EXPECT_LT(std::abs(d.depth_m - true_z), 4 * d.sigma_m + 1e-3) << "sigma " << d.sigma_m;
    EXPECT_TRUE(std::isnan(d.sigma_calib_m)) << "a rig without covariance has no calibration sigma";
  }
}

}  // namespace
}  // namespace owlcal::evaluation

namespace owlcal::evaluation {
namespace {

TEST(StereoDepth, DisparityConstantRecoversSixteenFBAndLeavesOneOut) {
  // Exact disp16 = 16 f B / Z with f = 580 px, B = 0.064 m, one row off by +2 %.
  const double fb16 = 16 * 580 * 0.064;
  std::vector<double> z = {0.3, 0.5, 0.7, 0.9, 1.2, 1.5}, d16;
  for (double v : z) d16.push_back(fb16 / v);
  d16[2] *= 1.02;
  d16.push_back(std::numeric_limits<double>::quiet_NaN());  // a refused row
  z.push_back(1.0);
  const DisparityConstantFit f = FitDisparityConstant(d16, z, 580, 0.064);
  EXPECT_EQ(f.num_rows, 6);
  EXPECT_NEAR(f.k_calibration, fb16, 1e-9);
  EXPECT_NEAR(f.k_disp16_m, fb16 * (1 + 0.02 / 6), 1e-6 * fb16);
  EXPECT_GT(f.k_cv_pct, 0.5);
  EXPECT_NEAR(f.max_abs_pct, 100 * (1 - (1 + 0.02 / 6) / 1.02), 1e-6);
  EXPECT_TRUE(std::isnan(f.estimate_m[6]));
  EXPECT_GT(f.loo_mean_abs_pct, f.mean_abs_pct);
}

TEST(StereoDepth, RefusesARoiWithoutDisparitiesAndBadOptions) {
  DepthOptions o;
  std::string why;
  o.sgbm.num_disparities = 100;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("num_disparities"), std::string::npos) << why;
  o = {};
  o.sgbm.block_size = 4;
  EXPECT_FALSE(o.Check(&why));
  o = {};
  // A blank pair: no texture, so no disparity anywhere; the ROI is refused with a reason.
  fitting::StereoRig rig;
  rig.right_from_left.translation = Eigen::Vector3d(-0.065, 0, 0);
  const fitting::Rectification rect = fitting::RectifyRig(rig, o.rectify_alpha);
  const cv::Mat blank(480, 640, CV_8U, cv::Scalar(128));
  const DepthMaps maps = ComputeDepth(blank, blank, rect, o);
  const RoiDepth d = DepthAtRoi(maps, cv::Rect(300, 220, 40, 30), rig, rect, o);
  EXPECT_FALSE(d.ok);
  EXPECT_NE(d.message.find("have a disparity"), std::string::npos) << d.message;
  EXPECT_FALSE(DepthAtRoi(maps, cv::Rect(700, 10, 20, 20), rig, rect, o).ok);
  EXPECT_THROW(ComputeDepth(cv::Mat(240, 320, CV_8U), cv::Mat(240, 320, CV_8U), rect, o), std::invalid_argument);
}

}  // namespace
}  // namespace owlcal::evaluation
