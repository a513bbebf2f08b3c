// Intrinsics fit on synthetic views with known truth: accuracy vs the reported sigma,
// outliers, fixed parameters and degenerate inputs.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "calib/target.h"
#include "fitting/intrinsics_fit.h"

namespace owlcal::fitting {
namespace {

models::CameraIntrinsics Truth() {
  models::CameraIntrinsics c;
  c.params = {585.0, 583.0, 322.0, 236.0, -0.12, 0.08, 0.0008, -0.0005, -0.02};
  return c;
}

// Board poses: tilted up to ~35 deg, at 0.35-0.6 m, covering the image.
std::vector<models::Rigid3d> Poses(int n, std::mt19937* rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<models::Rigid3d> poses;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d axis(u(*rng), u(*rng), 0.2 * u(*rng));
    const double angle = 0.15 + 0.45 * std::abs(u(*rng));
    const Eigen::Quaterniond q(Eigen::AngleAxisd(angle, axis.normalized()));
    const double z = 0.45 + 0.12 * u(*rng);
    // Board (0.21 x 0.13 m) centred near the optical axis, shifted around the image.
    const Eigen::Vector3d centre_in_board(0.104, 0.065, 0);
    const Eigen::Vector3d t = Eigen::Vector3d(0.12 * u(*rng), 0.09 * u(*rng), z) - q * centre_in_board;
    poses.emplace_back(q, t);
  }
  return poses;
}

std::vector<calib::View> Render(const models::CameraIntrinsics& cam,
                                const std::vector<models::Rigid3d>& poses,
                                double noise_px,
                                std::mt19937* rng) {
  calib::TargetDefinition board;  // 9x6, 26 mm
  std::normal_distribution<double> n(0, noise_px);
  std::vector<calib::View> views;
  for (size_t k = 0; k < poses.size(); ++k) {
    calib::View v;
    v.frame_index = int(k);
    for (const auto& [id, p] : board.Corners()) {
      const Eigen::Vector3d pc = poses[k] * p;
      double px[2];
      if (!cam.Project(pc.data(), px) || px[0] < 0 || px[1] < 0 || px[0] > 639 || px[1] > 479) continue;
      v.corner_ids.push_back(id);
      v.pixels.emplace_back(px[0] + n(*rng), px[1] + n(*rng));
      v.points_in_target.push_back(p);
    }
    views.push_back(v);
  }
  return views;
}

TEST(FitIntrinsicsSynthetic, RecoversTruthWithinReportedSigma) {
  std::mt19937 rng(42);
  const auto truth = Truth();
  const auto views = Render(truth, Poses(20, &rng), 0.2, &rng);
  const IntrinsicsFit fit = FitIntrinsics(views, 640, 480, IntrinsicsFitOptions());
  ASSERT_TRUE(fit.ok) << fit.message;
  EXPECT_NEAR(fit.corner_sigma_px, 0.2, 0.02);
  int within3 = 0, determined = 0;
  for (size_t i = 0; i < truth.params.size(); ++i) {
    if (!fit.determined[i]) continue;
    ++determined;
    const double z = std::abs(fit.camera.params[i] - truth.params[i]) / fit.sigmas[i];
    if (z <= 3) ++within3;
    EXPECT_LT(z, 4.5) << fit.param_names[i] << " " << fit.camera.params[i] << " vs " << truth.params[i] << " sigma "
                      << fit.sigmas[i];
  }
  EXPECT_GE(determined, 8);
  EXPECT_GE(within3, determined - 1);
  EXPECT_LT(fit.sigmas[0], 3.0);  // fx known to better than 0.5 %
  EXPECT_TRUE(fit.rejected.empty());
}

TEST(FitIntrinsicsSynthetic, OutlierCornerIsRejectedAndReported) {
  std::mt19937 rng(7);
  auto views = Render(Truth(), Poses(12, &rng), 0.15, &rng);
  views[3].pixels[10] += Eigen::Vector2d(6.0, -4.0);
  const IntrinsicsFit fit = FitIntrinsics(views, 640, 480, IntrinsicsFitOptions());
  ASSERT_TRUE(fit.ok) << fit.message;
  ASSERT_EQ(fit.rejected.size(), 1u);
  EXPECT_EQ(fit.rejected[0].frame_index, 3);
  EXPECT_EQ(fit.rejected[0].corner_id, views[3].corner_ids[10]);
  EXPECT_GT(fit.rejected[0].residual_px, 3.0);
  EXPECT_LT(fit.rms_px, 0.3);
}

TEST(FitIntrinsicsSynthetic, FixedParametersAreNamedNotSilentlyReported) {
  std::mt19937 rng(3);
  const auto views = Render(Truth(), Poses(12, &rng), 0.2, &rng);
  IntrinsicsFitOptions o;
  o.fix_k3 = true;
  o.fix_tangential = true;
  const IntrinsicsFit fit = FitIntrinsics(views, 640, 480, o);
  ASSERT_TRUE(fit.ok) << fit.message;
  EXPECT_FALSE(fit.determined[8]);
  EXPECT_EQ(fit.camera.params[8], 0.0);
  EXPECT_TRUE(std::isnan(fit.sigmas[8]));
  bool named = false;
  for (const auto& u : fit.undetermined) named = named || u.rfind("k3: fixed", 0) == 0;
  EXPECT_TRUE(named);
  CalibrationResult r;
  AppendIntrinsicsToResult(fit, "left", &r);
  ASSERT_NE(r.Find("left.k3"), nullptr);
  EXPECT_FALSE(r.Find("left.k3")->determined);
  EXPECT_NE(r.Find("left.k3")->note.find("fix_k3"), std::string::npos);
  EXPECT_TRUE(r.Find("left.fx")->determined);
}

TEST(FitIntrinsicsSynthetic, BoardNeverMovedNamesWhatCannotBeDetermined) {
  std::mt19937 rng(5);
  const auto pose = Poses(1, &rng);
  const auto views = Render(Truth(), {pose[0], pose[0], pose[0], pose[0]}, 0.2, &rng);
  const IntrinsicsFit fit = FitIntrinsics(views, 640, 480, IntrinsicsFitOptions());
  EXPECT_FALSE(fit.ok);
  EXPECT_NE(fit.message.find("ONE orientation"), std::string::npos) << fit.message;
  EXPECT_NE(fit.message.find("fx"), std::string::npos) << fit.message;
  EXPECT_FALSE(fit.undetermined.empty());
  CalibrationResult r;
  AppendIntrinsicsToResult(fit, "right", &r);
  ASSERT_NE(r.Find("right.fx"), nullptr);
  EXPECT_FALSE(r.Find("right.fx")->determined);
  EXPECT_TRUE(std::isnan(r.Find("right.fx")->value));
}

TEST(FitIntrinsicsSynthetic, TooFewCornersAndNoViews) {
  std::mt19937 rng(9);
  auto views = Render(Truth(), Poses(6, &rng), 0.2, &rng);
  for (auto& v : views) {
    v.pixels.resize(5);
    v.corner_ids.resize(5);
    v.points_in_target.resize(5);
  }
  IntrinsicsFit fit = FitIntrinsics(views, 640, 480, IntrinsicsFitOptions());
  EXPECT_FALSE(fit.ok);
  EXPECT_NE(fit.message.find("at least 8 corners"), std::string::npos) << fit.message;
  EXPECT_EQ(fit.dropped_views.size(), 6u);
  fit = FitIntrinsics({}, 640, 480, IntrinsicsFitOptions());
  EXPECT_FALSE(fit.ok);
  IntrinsicsFitOptions bad;
  bad.corner_sigma_px = -1;
  fit = FitIntrinsics(views, 640, 480, bad);
  EXPECT_FALSE(fit.ok);
  EXPECT_NE(fit.message.find("corner_sigma_px"), std::string::npos);
}

TEST(FitIntrinsicsSynthetic, RationalModelFits) {
  std::mt19937 rng(11);
  const auto views = Render(Truth(), Poses(20, &rng), 0.1, &rng);
  IntrinsicsFitOptions o;
  o.model = models::DistortionModel::kOpenCv8;
  const IntrinsicsFit fit = FitIntrinsics(views, 640, 480, o);
  ASSERT_TRUE(fit.ok) << fit.message;
  EXPECT_EQ(fit.camera.params.size(), 12u);
  EXPECT_LT(fit.rms_px, 0.2);
  EXPECT_NEAR(fit.camera.params[0], 585.0, 3.0);
  for (const auto& u : fit.undetermined) std::printf("rational: %s\n", u.c_str());
}

}  // namespace
}  // namespace owlcal::fitting
