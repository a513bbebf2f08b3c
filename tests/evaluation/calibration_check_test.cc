// Checking a calibration on new images.
//  - Synthetic rig (known truth, corner noise 0.3 px like a real Owl): calibrated on one set of
//    board poses, checked on an independent set. The calibration as fitted is "still valid";
//    deliberately perturbed copies (principal point, vertical misalignment, focal length,
//    baseline) are flagged "recalibrate", naming the parameter that moved.
//  - Real kit2020 set: the full-set calibration passes on its odd-numbered pairs, and the same
//    perturbations are flagged on real corners too.
#include "evaluation/calibration_check.h"

#include <cmath>
#include <functional>
#include <iostream>
#include <random>

#include <gtest/gtest.h>

#include "calib/image_pairs.h"
#include "calib/target_file.h"
#include "evaluation/range_images_calib.h"
#include "tests/shared_data.h"

namespace owlcal::evaluation {
namespace {

struct Rig {
  models::CameraIntrinsics cam[2];
  models::Rigid3d right_from_left;
};

Rig TruthRig() {
  Rig r;
  r.cam[0].params = {585.0, 584.0, 320.0, 238.0, -0.12, 0.08, 0.0, 0.0, 0.0};
  r.cam[1].params = {580.0, 579.5, 317.0, 242.0, -0.10, 0.05, 0.0, 0.0, 0.0};
  r.right_from_left =
      models::Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.02, Eigen::Vector3d(0.2, 1, 0.1).normalized())),
                      Eigen::Vector3d(-0.0645, 0.0008, 0.0012));
  return r;
}

// `num` views of the 9 x 6 (26 mm) board at 0.4-0.6 m, tilted up to ~30 deg, seen by both eyes.
std::vector<calib::CornerObservation> Observe(const Rig& rig, int num, uint32_t seed, double noise_px) {
  const calib::TargetDefinition board;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::normal_distribution<double> noise(0, noise_px);
  std::vector<calib::CornerObservation> out;
  for (int k = 0; k < num; ++k) {
    const Eigen::Vector3d axis(u(rng), u(rng), 0.2 * u(rng));
    const Eigen::Quaterniond q(Eigen::AngleAxisd(0.15 + 0.4 * std::abs(u(rng)), axis.normalized()));
    const Eigen::Vector3d t =
        Eigen::Vector3d(-0.03 + 0.1 * u(rng), 0.07 * u(rng), 0.5 + 0.1 * u(rng)) - q * Eigen::Vector3d(0.104, 0.065, 0);
    const models::Rigid3d left_from_target(q, t);
    for (int e = 0; e < 2; ++e) {
      const models::Rigid3d cam_from_target = e == 0 ? left_from_target : rig.right_from_left * left_from_target;
      for (const auto& [id, p] : board.Corners()) {
        const Eigen::Vector3d pc = cam_from_target * p;
        double px[2];
        if (!rig.cam[e].Project(pc.data(), px) || px[0] < 0 || px[1] < 0 || px[0] > 639 || px[1] > 479) continue;
        calib::CornerObservation o;
        o.frame_index = k;
        o.eye = e;
        o.target_id = board.id;
        o.corner_id = id;
        o.pixel = Eigen::Vector2d(px[0] + noise(rng), px[1] + noise(rng));
        o.point_in_target = p;
        out.push_back(o);
      }
    }
  }
  return out;
}

bool Named(const CalibrationCheck& c, const std::string& name) {
  for (const auto& m : c.moved)
    if (m.rfind(name + " ", 0) == 0) return true;
  return false;
}

void Print(const char* what, const CalibrationCheck& c) {
  std::cout << what << ": " << c.verdict << "; joint RMS " << c.rms_joint_px << " +- " << c.sigma_rms_joint_px
            << " px (refit " << c.refit_all_rms_px << "), epipolar RMS " << c.epipolar_rms_dy_px << " px, mean dy "
            << c.epipolar_mean_dy_px << " +- " << c.sigma_epipolar_mean_dy_px << ", range at 1 m " << c.range_at_1m_m
            << " +- " << c.sigma_range_at_1m_m << " m; moved:";
  for (const auto& m : c.moved) std::cout << " [" << m << "]";
  std::cout << "\n";
}

// The perturbations, each with the parameter(s) a check must name (a right principal point
// shift and a toe-in are nearly the same thing to a board a metre away: either is right).
struct Perturbation {
  const char* what;
  std::function<void(fitting::StereoRig*)> apply;
  std::vector<std::string> named;
};
std::vector<Perturbation> Perturbations() {
  return {
      {"right cx +4 px", [](fitting::StereoRig* r) { r->cameras[1].params[2] += 4.0; }, {"right.cx", "stereo.ry_deg"}},
      {"rx +0.25 deg (vertical misalignment)",
       [](fitting::StereoRig* r) {
         r->right_from_left.rotation =
             Eigen::AngleAxisd(0.25 * M_PI / 180, Eigen::Vector3d::UnitX()) * r->right_from_left.rotation;
       },
       {"stereo.rx_deg", "right.cy", "left.cy"}},
      {"left f +2 %",
       [](fitting::StereoRig* r) {
         r->cameras[0].params[0] *= 1.02;
         r->cameras[0].params[1] *= 1.02;
       },
       {"left.fx", "left.fy"}},
      {"baseline +3 %", [](fitting::StereoRig* r) { r->right_from_left.translation *= 1.03; }, {"stereo.tx_mm"}},
  };
}

void ExpectFlagged(const fitting::StereoRig& calibrated,
                   const std::vector<calib::CornerObservation>& check,
                   size_t how_many) {
  const std::vector<Perturbation> all = Perturbations();
  for (size_t i = 0; i < std::min(how_many, all.size()); ++i) {
    const Perturbation& p = all[i];
    SCOPED_TRACE(p.what);
    fitting::StereoRig r = calibrated;
    p.apply(&r);
    const CalibrationCheck c = CheckCalibration(r, check);
    ASSERT_TRUE(c.ok) << c.message;
    Print(p.what, c);
    EXPECT_EQ(c.verdict, "recalibrate");
    bool named = false;
    for (const auto& n : p.named) named |= Named(c, n);
    EXPECT_TRUE(named) << "none of the expected parameters named as moved";
  }
}

TEST(CalibrationCheck, SyntheticRigPassesOnNewViewsAndFlagsEachPerturbation) {
  const Rig truth = TruthRig();
  const ImageSetCalibration cal = CalibrateImageSet(Observe(truth, 16, 21, 0.3), fitting::StereoFitOptions{});
  ASSERT_TRUE(cal.fit.ok) << cal.fit.message;
  const fitting::StereoRig rig = fitting::RigFromStereoFit(cal.fit);
  const auto check = Observe(truth, 10, 99, 0.3);  // other poses, other noise
  const CalibrationCheck c = CheckCalibration(rig, check);
  ASSERT_TRUE(c.ok) << c.message;
  Print("synthetic, as calibrated", c);
  EXPECT_EQ(c.verdict, "still valid");
  for (const auto& r : c.reasons) ADD_FAILURE() << r;
  EXPECT_TRUE(c.moved.empty());
  EXPECT_NEAR(c.corner_sigma_px, 0.3, 0.03);
  EXPECT_NEAR(c.rms_joint_px, 0.3 * std::sqrt(2.0), 0.05);  // |e| of a 2-D error with 0.3 px per axis
  EXPECT_LT(std::abs(c.range_at_1m_m - 1.0), 3 * c.sigma_range_at_1m_m + 1e-4);
  ExpectFlagged(rig, check, 4);
}

struct KitSplit {
  fitting::StereoRig rig;
  std::vector<calib::CornerObservation> odd;
};
const KitSplit& Kit() {
  static const KitSplit s = [] {
    const std::string dir = test_data::SharedData() + "/owl-real/kit2020-chessboard";
    const calib::TargetDefinition board =
        calib::LoadTargetFile(test_data::SharedData() + "/targets/owl-kit-chessboard.yaml");
    const auto set = calib::DetectImagePairs(calib::ListImagePairs(dir, {}), {}, board, {});
    KitSplit out;
    for (const auto& o : set.observations)
      if (o.frame_index % 2) out.odd.push_back(o);
    const ImageSetCalibration c = CalibrateImageSet(set.observations, fitting::StereoFitOptions{});
    EXPECT_TRUE(c.fit.ok) << c.fit.message;
    out.rig = fitting::RigFromStereoFit(c.fit);
    return out;
  }();
  return s;
}

TEST(CalibrationCheck, RealKitCalibrationPassesAndPerturbedCopiesAreFlagged) {
  const KitSplit& s = Kit();
  const CalibrationCheck c = CheckCalibration(s.rig, s.odd);
  ASSERT_TRUE(c.ok) << c.message;
  Print("kit2020, as calibrated", c);
  EXPECT_GE(c.num_pairs, 10);
  EXPECT_EQ(c.verdict, "still valid");
  for (const auto& r : c.reasons) ADD_FAILURE() << r;
  EXPECT_TRUE(c.calibration_has_covariance);
  // Real Owl corners: 0.25-0.45 px (docs/conventions.md, Facts); the sigma of an RMS over ~1300 corners is small.
  EXPECT_LT(c.rms_joint_px, 0.6);
  EXPECT_GT(c.sigma_rms_joint_px, 0);
  EXPECT_LT(c.sigma_rms_joint_px, 0.05 * c.rms_joint_px);
  ExpectFlagged(s.rig, s.odd, 2);  // the other two on the synthetic rig (time)
}

TEST(CalibrationCheck, TooFewPairsGivesNoVerdict) {
  const Rig truth = TruthRig();
  const ImageSetCalibration cal = CalibrateImageSet(Observe(truth, 12, 5, 0.3), fitting::StereoFitOptions{});
  const fitting::StereoRig rig = fitting::RigFromStereoFit(cal.fit);
  const CalibrationCheck c = CheckCalibration(rig, Observe(truth, 2, 6, 0.3));
  EXPECT_FALSE(c.ok);
  EXPECT_TRUE(c.verdict.empty());
  EXPECT_NE(c.message.find("needs 3"), std::string::npos) << c.message;
  CalibrationCheckOptions o;
  o.max_rms_ratio = 0.5;
  EXPECT_THROW(CheckCalibration(rig, Observe(truth, 5, 7, 0.3), o), std::invalid_argument);
}

}  // namespace
}  // namespace owlcal::evaluation
