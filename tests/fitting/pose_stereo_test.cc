// Stereo at any commanded pose (fitting/pose_stereo.h): a head fitted on a
// synthetic servo sweep predicts R, T at five verged poses (18-54 us toe-in per eye); the truth
// lies within 3 sigma of the prediction, and a stereo calibration fitted directly at each pose
// agrees with it within the combined sigma.
#include "fitting/pose_stereo.h"

#include <cmath>
#include <iostream>
#include <random>

#include <gtest/gtest.h>

#include "evaluation/truth_compare.h"
#include "fitting/head_fit.h"
#include "fitting/head_synthetic.h"
#include "fitting/stereo_fit.h"

namespace owlcal::fitting {
namespace {

const char* kRot[3] = {"stereo.rx_deg", "stereo.ry_deg", "stereo.rz_deg"};
const char* kT[3] = {"stereo.tx", "stereo.ty", "stereo.tz"};

// Stereo views of a 9 x 6, 26 mm board at 15 poses in front of the left camera, projected
// through the two cameras and right_from_left with Gaussian noise (as a student's stereo set at
// that head pose).
void SynthesizeStereo(const models::CameraIntrinsics cam[2],
                      const models::Rigid3d& right_from_left,
                      double noise_px,
                      std::mt19937* rng,
                      std::vector<calib::View> views[2]) {
  calib::TargetDefinition board;
  std::uniform_real_distribution<double> u(-1, 1);
  std::normal_distribution<double> noise(0, noise_px);
  for (int k = 0; k < 15; ++k) {
    const Eigen::Vector3d axis(u(*rng), u(*rng), 0.2 * u(*rng));
    const Eigen::Quaterniond q(Eigen::AngleAxisd(0.15 + 0.4 * std::abs(u(*rng)), axis.normalized()));
    const Eigen::Vector3d t = Eigen::Vector3d(-0.03 + 0.1 * u(*rng), 0.07 * u(*rng), 0.5 + 0.1 * u(*rng)) -
                              q * Eigen::Vector3d(0.104, 0.065, 0);
    const models::Rigid3d left_from_target(q, t);
    for (int e = 0; e < 2; ++e) {
      const models::Rigid3d cam_from_target = e == 0 ? left_from_target : right_from_left * left_from_target;
      calib::View v;
      v.frame_index = k;
      v.eye = e;
      for (const auto& [id, p] : board.Corners()) {
        const Eigen::Vector3d pc = cam_from_target * p;
        double px[2];
        if (!cam[e].Project(pc.data(), px) || px[0] < 0 || px[1] < 0 || px[0] > 639 || px[1] > 479) continue;
        v.corner_ids.push_back(id);
        v.pixels.emplace_back(px[0] + noise(*rng), px[1] + noise(*rng));
        v.points_in_target.push_back(p);
      }
      if (v.pixels.size() >= 8) views[e].push_back(v);
    }
  }
}

class PoseStereoTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    std::mt19937_64 rng(20261126);
    robot_ = new models::RobotConfig(models::DefaultRobotConfig());
    truth_ = new models::HeadModel(PerturbedHead(*robot_, &rng));
    SyntheticHeadOptions so;
    so.steps_per_sweep = 6;
    so.grid_side = 4;
    const SyntheticHeadData data = SynthesizeHeadViews(*truth_, *robot_, so, &rng);
    models::HeadModel init = models::NominalHeadModel(*robot_);
    init.intrinsics[0] = truth_->intrinsics[0];  // "from a prior intrinsics fit"
    init.intrinsics[1] = truth_->intrinsics[1];
    fit_ = new HeadFit(FitHead(data.views, *robot_, init, HeadFitOptions()));
  }
  static void TearDownTestSuite() {
    delete fit_;
    delete truth_;
    delete robot_;
  }
  static models::RobotConfig* robot_;
  static models::HeadModel* truth_;
  static HeadFit* fit_;
};
models::RobotConfig* PoseStereoTest::robot_ = nullptr;
models::HeadModel* PoseStereoTest::truth_ = nullptr;
HeadFit* PoseStereoTest::fit_ = nullptr;

TEST_F(PoseStereoTest, PredictsTheTruthAndADirectStereoFitAtFiveVergedPoses) {
  ASSERT_TRUE(fit_->ok) << fit_->message;
  const NamedCovariance cov{fit_->param_names, fit_->covariance};
  std::mt19937 rng(17);
  const int toe_in_us[5] = {18, 27, 36, 45, 54};
  const int tilt_us[5] = {0, 20, -20, 40, -40};
  const int neck_us[5] = {0, 60, -60, 0, 120};  // turns both eyes together: no effect on R, T
  int compared = 0, within2 = 0;
  for (int k = 0; k < 5; ++k) {
    // Converging: Rx down and Lx up (docs/conventions.md), each approached from the centre.
    models::PwmVector pwm = robot_->Centre();
    pwm[models::kRx] -= toe_in_us[k];
    pwm[models::kLx] += toe_in_us[k];
    pwm[models::kRy] += tilt_us[k];
    pwm[models::kLy] -= tilt_us[k];  // the left tilt is mirrored: both eyes look the same way
    pwm[models::kNeck] += neck_us[k];
    PoseStereoOptions o;
    o.approach = {-1, tilt_us[k] >= 0 ? 1 : -1, 1, tilt_us[k] >= 0 ? -1 : 1, 0};
    const PoseStereo s = StereoAtPose(fit_->head, cov, pwm, o);
    ASSERT_TRUE(s.ok) << s.message;
    EXPECT_GE(s.propagated.size(), 30u);
    // Truth: the truth head's cameras at this command (evaluation/truth_compare.h, another path).
    const auto truth = evaluation::StereoTruthValues(*truth_, pwm, o.approach);
    // A stereo calibration fitted at this pose from 15 board views with 0.15 px noise.
    std::vector<calib::View> views[2];
    SynthesizeStereo(truth_->intrinsics,
                     RightFromLeftAtPose(
                         *truth_,
                         [&] {
                           std::array<double, models::kNumServos> d{};
                           for (int i = 0; i < models::kNumServos; ++i) d[i] = pwm[i];
                           return d;
                         }(),
                         o.approach),
                     0.15,
                     &rng,
                     views);
    const StereoFit direct = FitStereo(views[0], views[1], StereoFitOptions());
    ASSERT_TRUE(direct.ok) << direct.message;
    CalibrationResult dr;
    AppendStereoToResult(direct, &dr);
    // The direct fit and the prediction as 6-vectors [rotation vector (rad), T (m)] with their
    // full covariances (the direct fit's R and T are strongly correlated): the Mahalanobis
    // distance is chi-square with 6 degrees of freedom; 22.46 is its 99.9 % point.
    const Eigen::Index ro = direct.covariance.rows() - 6;
    const Eigen::AngleAxisd dd(direct.right_from_left.rotation * s.right_from_left.rotation.inverse());
    Eigen::Matrix<double, 6, 1> diff;
    diff.head<3>() = dd.angle() * dd.axis();
    diff.tail<3>() = direct.right_from_left.translation - s.right_from_left.translation;
    const Eigen::Matrix<double, 6, 6> both = direct.covariance.block(ro, ro, 6, 6) + s.covariance;
    const double chi2 = diff.dot(both.ldlt().solve(diff));
    EXPECT_LT(chi2, 22.46) << "direct stereo fit at toe-in " << toe_in_us[k];
    std::cout << "toe-in " << toe_in_us[k] << " us, tilt " << tilt_us[k] << " us:";
    for (int j = 0; j < 6; ++j) {
      const std::string name = j < 3 ? kRot[j] : kT[j - 3];
      const Parameter* p = s.result.Find(name);
      const Parameter* d = dr.Find(name);
      ASSERT_NE(p, nullptr);
      ASSERT_NE(d, nullptr);
      const double t = truth.at(name);
      ASSERT_GT(p->sigma, 0) << name;
      const double z = (p->value - t) / p->sigma;
      const double zd = (d->value - p->value) / std::hypot(d->sigma, p->sigma);
      std::cout << " " << name << " " << p->value << " +- " << p->sigma << " (truth " << t << ", z " << z << "; direct "
                << d->value << " +- " << d->sigma << ", z " << zd << ")";
      EXPECT_LT(std::abs(z), 3.0) << name << " at toe-in " << toe_in_us[k];
      EXPECT_LT(std::abs(zd), 4.0) << name << " direct fit at toe-in " << toe_in_us[k];
      ++compared;
      within2 += std::abs(z) <= 2;
    }
    std::cout << " chi2 (6 dof) vs direct " << chi2 << "\n";
    // The rotation is known to a fraction of a degree, T to about a millimetre.
    EXPECT_LT(s.result.Find("stereo.ry_deg")->sigma, 0.2);
    EXPECT_LT(s.result.Find("stereo.baseline_mm")->sigma, 1.0);
    // Verged: the relative yaw grows with the toe-in (both eyes turn inwards).
    EXPECT_GT(std::abs(s.result.Find("stereo.ry_deg")->value), 2 * toe_in_us[k] * 0.09);
    // OpenCV's fields follow: E = [T]x R, rectified rows.
    ASSERT_FALSE(s.opencv.E.empty());
    ASSERT_FALSE(s.opencv.Q.empty());
  }
  // Gaussian errors: most within 2 sigma (not a test that cannot fail: 30 values).
  EXPECT_GE(within2, compared * 3 / 4) << within2 << " of " << compared;
}

TEST_F(PoseStereoTest, ResultPathMatchesTheDirectCallAndRefusesAHeadlessResult) {
  ASSERT_TRUE(fit_->ok) << fit_->message;
  // As owlcal calibrate stores a head fit: parameters, head, diagnostics.covariance.
  CalibrationResult r = fit_->result;
  nlohmann::json m = nlohmann::json::array();
  for (int i = 0; i < fit_->covariance.rows(); ++i) {
    std::vector<double> row(fit_->covariance.cols());
    for (int j = 0; j < fit_->covariance.cols(); ++j) row[j] = fit_->covariance(i, j);
    m.push_back(row);
  }
  r.diagnostics["covariance"] = {{"names", fit_->param_names}, {"matrix", m}};
  models::PwmVector pwm = robot_->Centre();
  pwm[models::kRx] -= 36;
  pwm[models::kLx] += 36;
  const PoseStereo a = StereoAtPose(r, pwm);
  const PoseStereo b = StereoAtPose(fit_->head, NamedCovariance{fit_->param_names, fit_->covariance}, pwm);
  ASSERT_TRUE(a.ok) << a.message;
  ASSERT_TRUE(b.ok);
  EXPECT_LT((a.covariance - b.covariance).norm(), 1e-9 * b.covariance.norm());
  EXPECT_LT((a.right_from_left.translation - b.right_from_left.translation).norm(), 1e-12);
  // Unknown approach sides widen the sigma (the backlash band), never narrow it.
  PoseStereoOptions known;
  known.approach = {-1, 0, 1, 0, 0};
  const PoseStereo c = StereoAtPose(r, pwm, known);
  ASSERT_TRUE(c.ok);
  EXPECT_GT(a.result.Find("stereo.ry_deg")->sigma, c.result.Find("stereo.ry_deg")->sigma);

  CalibrationResult headless;
  const PoseStereo h = StereoAtPose(headless, pwm);
  EXPECT_FALSE(h.ok);
  EXPECT_NE(h.message.find("no head"), std::string::npos) << h.message;
  CalibrationResult nominal;
  nominal.head = models::NominalHeadModel(*robot_);
  const PoseStereo n = StereoAtPose(nominal, pwm);
  EXPECT_FALSE(n.ok);
  EXPECT_NE(n.message.find("not fitted"), std::string::npos) << n.message;
  PoseStereoOptions bad;
  bad.approach[0] = 2;
  EXPECT_FALSE(StereoAtPose(r, pwm, bad).ok);
}

}  // namespace
}  // namespace owlcal::fitting
