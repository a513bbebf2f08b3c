#include "fitting/head_fit.h"

#include <algorithm>
#include <cmath>
#include <iostream>
#include <random>

#include <gtest/gtest.h>

#include "evaluation/servo_map_eval.h"
#include "fitting/head_synthetic.h"
#include "models/head_model.h"
#include "models/servo_map.h"

namespace owlcal::fitting {
namespace {

using models::kNeck;
using models::kNumServos;

models::HeadModel InitialFor(const models::RobotConfig& robot, const models::HeadModel& truth) {
  models::HeadModel init = models::NominalHeadModel(robot);
  init.intrinsics[0] = truth.intrinsics[0];  // "from a prior intrinsics fit"
  init.intrinsics[1] = truth.intrinsics[1];
  return init;
}

bool IsDetermined(const CalibrationResult& r, const std::string& name) {
  const Parameter* p = r.Find(name);
  return p != nullptr && p->determined && std::isfinite(p->sigma);
}

// True if one warning contains both strings.
bool HasWarning(const CalibrationResult& r, const std::string& a, const std::string& b) {
  for (const std::string& w : r.warnings)
    if (w.find(a) != std::string::npos && w.find(b) != std::string::npos) return true;
  return false;
}

// True if one note contains both strings.
bool HasNote(const CalibrationResult& r, const std::string& a, const std::string& b) {
  for (const std::string& n : r.notes)
    if (n.find(a) != std::string::npos && n.find(b) != std::string::npos) return true;
  return false;
}

std::string AllWarnings(const CalibrationResult& r) {
  std::string s;
  for (const std::string& w : r.warnings) s += w + "\n";
  return s;
}

// Checks the acceptance criteria for the head and returns the number of
// determined parameters compared with the truth.
int ExpectAccurate(const HeadFit& fit, const models::HeadModel& truth_canonical, const models::RobotConfig& robot) {
  CalibrationResult r = fit.result;
  SetHeadTruth(truth_canonical, &r);
  const Parameter* ipd = r.Find("head.ipd_mm");
  EXPECT_TRUE(ipd && ipd->determined);
  EXPECT_NEAR(ipd->value, truth_canonical.geometry.Ipd() * 1000, 0.5);
  for (int i = 0; i < kNumServos; ++i) {
    if (!IsDetermined(r, std::string("servo.") + models::kServoNames[i] + ".deg_per_us")) continue;
    const double rms = evaluation::ServoMapRmsDeg(fit.head.servo_params[i].data(),
                                                  truth_canonical.servo_params[i].data(),
                                                  robot.servos[i].direction,
                                                  robot.servos[i].min_us,
                                                  robot.servos[i].max_us);
    EXPECT_LT(rms, 0.1) << models::kServoNames[i];
  }
  int compared = 0, within3 = 0;
  for (const Parameter& p : r.parameters) {
    if (!p.determined || !p.truth) continue;
    ++compared;
    const double z = std::abs(p.value - *p.truth) / p.sigma;
    EXPECT_LT(z, 4.0) << p.name << " = " << p.value << " +- " << p.sigma << ", truth " << *p.truth;
    if (z <= 3.0) ++within3;
  }
  EXPECT_GE(within3, compared - 1) << "of " << compared;
  return compared;
}

// The cluster spec has one parser (CovarianceClusters::Parse), used by owlcal fit-datasets and
// inverted by Spec (what results.json records); a malformed cell is refused, not read as no
// cells or as its prefix, and a cell below 1 us set in code fails Check.
TEST(HeadFitOptions, CovarianceClusterSpecsAreParsedOnceAndMalformedOnesRefused) {
  using Kind = CovarianceClusters::Kind;
  ASSERT_TRUE(CovarianceClusters::Parse("cell:100"));
  EXPECT_EQ(CovarianceClusters::Parse("cell:100")->kind, Kind::kCell);
  EXPECT_EQ(CovarianceClusters::Parse("cell:100")->cell_us, 100.0);
  EXPECT_EQ(CovarianceClusters::Parse("cell:2.5")->cell_us, 2.5);
  EXPECT_EQ(CovarianceClusters::Parse("view")->kind, Kind::kView);
  EXPECT_EQ(CovarianceClusters::Parse("model")->kind, Kind::kModel);
  EXPECT_EQ(CovarianceClusters::Parse("")->kind, Kind::kModel);
  for (const char* spec : {"", "view", "placement", "cell:100", "cell:2.5"})
    EXPECT_EQ(CovarianceClusters::Parse(spec)->Spec(), spec);
  for (const char* bad : {"cell:", "cell:0", "cell:0.5", "cell:100us", "frame"})
    EXPECT_FALSE(CovarianceClusters::Parse(bad)) << bad;
  HeadFitOptions o;
  std::string why;
  o.covariance_clusters = CovarianceClusters::Cell(100);
  EXPECT_TRUE(o.Check(&why)) << why;
  o.covariance_clusters = CovarianceClusters::Cell(0.5);
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("covariance_clusters"), std::string::npos) << why;
  for (const FloorCarry c : {FloorCarry::kNone, FloorCarry::kCentres, FloorCarry::kServoMaps})
    EXPECT_EQ(ParseFloorCarry(FloorCarryName(c)), c);
  EXPECT_FALSE(ParseFloorCarry("scales"));
}

// A perturbed default robot and its synthetic sweep (4 x 4 corner grids).
struct SyntheticSweep {
  models::RobotConfig robot = models::DefaultRobotConfig();
  models::HeadModel truth;
  SyntheticHeadData data;
};
SyntheticSweep MakeSweep(uint64_t seed, int steps_per_sweep) {
  std::mt19937_64 rng(seed);
  SyntheticSweep w;
  w.truth = PerturbedHead(w.robot, &rng);
  SyntheticHeadOptions so;
  so.steps_per_sweep = steps_per_sweep;
  so.grid_side = 4;
  w.data = SynthesizeHeadViews(w.truth, w.robot, so, &rng);
  return w;
}

TEST(FitHead, RecoversServoMapsMountsAndIpdFromSweepWithNeck) {
  const SyntheticSweep sweep = MakeSweep(20261122, 6);
  const models::RobotConfig& robot = sweep.robot;
  const models::HeadModel& truth = sweep.truth;
  const SyntheticHeadData& data = sweep.data;
  HeadFitOptions opt;
  const HeadFit fit = FitHead(data.views, robot, InitialFor(robot, truth), opt);
  ASSERT_TRUE(fit.ok) << fit.message << "\n" << AllWarnings(fit.result);
  EXPECT_NEAR(fit.result.summaries[0].rms_px, 0.15 * std::sqrt(2.0), 0.03);
  EXPECT_EQ(fit.result.diagnostics["head"]["null_space_dimension"], 0);
  EXPECT_TRUE(fit.outliers.empty());
  // Everything that the gauge leaves free is determined, including the neck's scale.
  for (int i = 0; i < kNumServos; ++i) {
    for (const char* k : {"deg_per_us", "quad_deg", "cubic_deg", "hysteresis_us"})
      EXPECT_TRUE(IsDetermined(fit.result, std::string("servo.") + models::kServoNames[i] + "." + k))
          << models::kServoNames[i] << "." << k;
  }
  EXPECT_FALSE(fit.result.Find("servo.Neck.centre_us")->determined);
  EXPECT_NE(fit.result.Find("servo.Neck.centre_us")->note.find("gauge"), std::string::npos);
  EXPECT_TRUE(IsDetermined(fit.result, "head.left.mount_yaw_deg"));
  EXPECT_TRUE(IsDetermined(fit.result, "head.left.centre_x_mm"));
  const int compared = ExpectAccurate(fit, truth, robot);
  EXPECT_GE(compared, 40);
  std::cout << "timing " << fit.result.diagnostics["head"]["timing"].dump() << " reciprocal condition "
            << fit.result.diagnostics["head"]["reciprocal_condition"] << " views " << fit.num_views_used << " corners "
            << fit.num_corners_used << "\n";
}

// HeadFitOptions::pan_zero_sigma_factor widens the pan zero (both pan maps' mean angle at the
// robot file's centres) by the factor and nothing else: the values, the tilt, neck and head
// sigmas are those of the fit without it.
TEST(FitHead, PanZeroFactorWidensOnlyThePanZero) {
  const SyntheticSweep sweep = MakeSweep(20261128, 5);
  const models::RobotConfig& robot = sweep.robot;
  const models::HeadModel& truth = sweep.truth;
  const SyntheticHeadData& data = sweep.data;
  HeadFitOptions opt;
  const HeadFit plain = FitHead(data.views, robot, InitialFor(robot, truth), opt);
  opt.pan_zero_sigma_factor = 2.0;
  const HeadFit wide = FitHead(data.views, robot, InitialFor(robot, truth), opt);
  ASSERT_TRUE(plain.ok && wide.ok) << plain.message << " / " << wide.message;
  ASSERT_EQ(plain.param_names, wide.param_names);
  // sigma of g = mean over both pans of the map's angle at the robot file's centre, from each
  // fit's covariance (numerical gradient of the map in its parameters).
  auto sigma_of_pan_zero = [&](const HeadFit& fit) {
    Eigen::VectorXd a = Eigen::VectorXd::Zero(Eigen::Index(fit.param_names.size()));
    for (int e = 0; e < 2; ++e) {
      const int servo = models::kPanServo[e];
      const auto& p = fit.head.servo_params[servo];
      for (int k = 0; k < 5; ++k) {
        const std::string name = std::string("servo.") + models::kServoNames[servo] + "." + kServoParamNames[k];
        const auto it = std::find(fit.param_names.begin(), fit.param_names.end(), name);
        if (it == fit.param_names.end()) continue;
        auto hi = p, lo = p;
        const double h = 1e-6 * std::max(1.0, std::abs(p[k]));
        hi[k] += h;
        lo[k] -= h;
        const int dir = robot.servos[servo].direction;
        const double u0 = robot.servos[servo].centre_us;
        a(it - fit.param_names.begin()) = 0.5 *
                                          (models::ServoMap::JointAngle(hi.data(), dir, u0, 0) -
                                           models::ServoMap::JointAngle(lo.data(), dir, u0, 0)) /
                                          (2 * h);
      }
    }
    return std::sqrt(a.dot(fit.covariance * a));
  };
  const double s1 = sigma_of_pan_zero(plain), s2 = sigma_of_pan_zero(wide);
  ASSERT_GT(s1, 0);
  EXPECT_NEAR(s2 / s1, 2.0, 1e-3) << s1 << " rad -> " << s2 << " rad";
  int pans_wider = 0;
  for (const Parameter& p : plain.result.parameters) {
    const Parameter* q = wide.result.Find(p.name);
    ASSERT_NE(q, nullptr) << p.name;
    EXPECT_EQ(p.value, q->value) << p.name;
    if (!(p.sigma > 0)) continue;
    const bool pan = p.name.rfind("servo.Lx.", 0) == 0 || p.name.rfind("servo.Rx.", 0) == 0;
    if (pan) {
      EXPECT_GE(q->sigma, p.sigma * (1 - 1e-12)) << p.name;
      pans_wider += q->sigma > 1.5 * p.sigma;
    } else {
      EXPECT_NEAR(q->sigma, p.sigma, 1e-12 * std::abs(p.sigma)) << p.name;
    }
  }
  EXPECT_GE(pans_wider, 2);  // at least both centres
  // The fit reports the pan zero's sigma after widening, and a floor on it widens the same way.
  const double reported = wide.result.diagnostics["head"]["pan_zero"]["sigma_deg"].get<double>();
  EXPECT_NEAR(reported * M_PI / 180.0 / s2, 1.0, 1e-3);
  opt.pan_zero_sigma_floor_deg = 1.5 * reported;  // above the 2x widening: the floor rules
  const HeadFit floored = FitHead(data.views, robot, InitialFor(robot, truth), opt);
  ASSERT_TRUE(floored.ok) << floored.message;
  EXPECT_NEAR(sigma_of_pan_zero(floored) / s2, 1.5, 1e-3);
  opt.pan_zero_sigma_floor_deg = 0.5 * reported;  // below: the factor rules
  const HeadFit below = FitHead(data.views, robot, InitialFor(robot, truth), opt);
  for (const Parameter& p : wide.result.parameters) {
    if (!(p.sigma > 0)) continue;
    EXPECT_NEAR(below.result.Find(p.name)->sigma, p.sigma, 1e-12 * p.sigma) << p.name;
  }
}

// The focal-scale floor: g = mean of log fx, log fy over both eyes gets exactly the floor's sigma,
// the servo scales (which a rotating camera sees only times the focal lengths) widen with it, the
// values do not move, and a floor below the fitted sigma changes nothing.
TEST(FitHead, FocalScaleFloorRaisesTheFocalScaleAndCarriesItToTheServoScales) {
  const SyntheticSweep sweep = MakeSweep(20261129, 5);
  HeadFitOptions opt;
  opt.fit_intrinsics = true;
  const HeadFit plain = FitHead(sweep.data.views, sweep.robot, InitialFor(sweep.robot, sweep.truth), opt);
  ASSERT_TRUE(plain.ok) << plain.message;
  auto sigma_of_g = [](const HeadFit& fit) {
    Eigen::VectorXd a = Eigen::VectorXd::Zero(Eigen::Index(fit.param_names.size()));
    int num = 0;
    for (const char* name : {"head.left.fx", "head.left.fy", "head.right.fx", "head.right.fy"}) {
      const auto it = std::find(fit.param_names.begin(), fit.param_names.end(), name);
      if (it == fit.param_names.end()) continue;
      a(it - fit.param_names.begin()) = 1.0 / fit.result.Find(name)->value;
      ++num;
    }
    EXPECT_EQ(num, 4);
    a /= num;
    return std::sqrt(a.dot(fit.covariance * a));
  };
  const double s0 = sigma_of_g(plain);
  ASSERT_GT(s0, 0);
  opt.focal_scale_sigma_floor = 3 * s0;
  const HeadFit floored = FitHead(sweep.data.views, sweep.robot, InitialFor(sweep.robot, sweep.truth), opt);
  ASSERT_TRUE(floored.ok) << floored.message;
  EXPECT_NEAR(sigma_of_g(floored) / s0, 3.0, 1e-6);
  EXPECT_NEAR(floored.result.diagnostics["head"]["focal_scale_floor"]["sigma_fitted"].get<double>(), s0, 1e-9 * s0);
  int scales_wider = 0;
  for (const Parameter& p : plain.result.parameters) {
    const Parameter* q = floored.result.Find(p.name);
    ASSERT_NE(q, nullptr) << p.name;
    EXPECT_EQ(p.value, q->value) << p.name;
    if (!(p.sigma > 0)) continue;
    EXPECT_GE(q->sigma, p.sigma * (1 - 1e-9)) << p.name;  // only ever widened
    if (p.name.find(".deg_per_us") != std::string::npos) scales_wider += q->sigma > 1.2 * p.sigma;
  }
  EXPECT_GE(scales_wider, 4) << "the servo scales follow the focal lengths";
  opt.focal_scale_sigma_floor = 0.5 * s0;
  const HeadFit below = FitHead(sweep.data.views, sweep.robot, InitialFor(sweep.robot, sweep.truth), opt);
  for (const Parameter& p : plain.result.parameters) {
    if (!(p.sigma > 0)) continue;
    EXPECT_EQ(below.result.Find(p.name)->sigma, p.sigma) << p.name;
  }
  // The left principal point raised to 9x its fitted covariance: its sigmas triple, nothing else
  // moves.
  opt.focal_scale_sigma_floor = 0;
  auto index = [&](const std::string& name) {
    return int(std::find(plain.param_names.begin(), plain.param_names.end(), name) - plain.param_names.begin());
  };
  const int cx = index("head.left.cx"), cy = index("head.left.cy");
  ASSERT_LT(cy, int(plain.param_names.size()));
  Eigen::Matrix2d pp;
  pp << plain.covariance(cx, cx), plain.covariance(cx, cy), plain.covariance(cy, cx), plain.covariance(cy, cy);
  opt.principal_point_covariance_floor[models::kLeftEye] = Eigen::MatrixXd(9 * pp);
  const HeadFit pp_floored = FitHead(sweep.data.views, sweep.robot, InitialFor(sweep.robot, sweep.truth), opt);
  ASSERT_TRUE(pp_floored.ok) << pp_floored.message;
  for (const char* name : {"head.left.cx", "head.left.cy"})
    EXPECT_NEAR(pp_floored.result.Find(name)->sigma / plain.result.Find(name)->sigma, 3.0, 1e-6) << name;
  for (const Parameter& p : plain.result.parameters) {
    if (!(p.sigma > 0) || p.name == "head.left.cx" || p.name == "head.left.cy") continue;
    EXPECT_EQ(pp_floored.result.Find(p.name)->sigma, p.sigma) << p.name;
  }
  opt.focal_scale_sigma_floor = -1;
  std::string why;
  EXPECT_FALSE(opt.Check(&why));
  EXPECT_NE(why.find("focal_scale_sigma_floor"), std::string::npos) << why;
  opt.focal_scale_sigma_floor = 0;
  opt.principal_point_covariance_floor[models::kRightEye] = Eigen::MatrixXd::Identity(3, 3);
  EXPECT_FALSE(opt.Check(&why));
  EXPECT_NE(why.find("principal_point_covariance_floor[1]"), std::string::npos) << why;
}

TEST(FitHead, NonCanonicalTruthMatchesItsCanonicalFormAndJointIntrinsics) {
  std::mt19937_64 rng(77);
  const models::RobotConfig robot = models::DefaultRobotConfig();
  // Mount pitch, unequal centre depths, neck centre off the robot file: all gauge.
  const models::HeadModel truth = PerturbedHead(robot, &rng, /*mount_pitch_deg_sigma=*/1.0, /*canonical=*/false);
  SyntheticHeadOptions so;
  so.steps_per_sweep = 6;
  so.grid_side = 3;
  const SyntheticHeadData data = SynthesizeHeadViews(truth, robot, so, &rng);
  HeadFitOptions opt;
  opt.fit_intrinsics = true;
  for (int e = 0; e < 2; ++e) {
    // A prior from an intrinsics fit: sigma 1 px on f and c, 0.01 on k1/k2, 1e-3 on p, 0.01 on k3.
    Eigen::VectorXd sd(9);
    sd << 1, 1, 1, 1, 0.01, 0.01, 1e-3, 1e-3, 0.01;
    opt.intrinsics_prior_covariance[e] = Eigen::MatrixXd(sd.cwiseAbs2().asDiagonal());
  }
  models::HeadModel init = InitialFor(robot, truth);
  for (int e = 0; e < 2; ++e) init.intrinsics[e].params[0] += 0.5;  // prior mean off by 0.5 sigma
  const HeadFit fit = FitHead(data.views, robot, init, opt);
  ASSERT_TRUE(fit.ok) << fit.message << "\n" << AllWarnings(fit.result);
  const models::HeadModel canon =
      CanonicalHead(truth, robot.servos[kNeck].centre_us, true, init.geometry.centre_in_head[models::kLeftEye]);
  EXPECT_TRUE(IsDetermined(fit.result, "head.left.fx"));
  EXPECT_LT(fit.result.Find("head.left.fx")->sigma, 1.0);  // data + prior beat the prior alone
  ExpectAccurate(fit, canon, robot);
}

TEST(FitHead, NeckNeverMovedNamesTheNeckAndStillGivesIpd) {
  std::mt19937_64 rng(5);
  const models::RobotConfig robot = models::DefaultRobotConfig();
  const models::HeadModel truth = PerturbedHead(robot, &rng);
  SyntheticHeadOptions so;
  so.move_neck = false;
  so.steps_per_sweep = 5;
  so.grid_side = 3;
  const SyntheticHeadData data = SynthesizeHeadViews(truth, robot, so, &rng);
  const HeadFit fit = FitHead(data.views, robot, InitialFor(robot, truth), HeadFitOptions());
  ASSERT_TRUE(fit.ok) << fit.message;
  for (const char* k : {"centre_us", "deg_per_us", "quad_deg", "cubic_deg", "hysteresis_us"}) {
    const Parameter* p = fit.result.Find(std::string("servo.Neck.") + k);
    ASSERT_NE(p, nullptr);
    EXPECT_FALSE(p->determined);
    EXPECT_TRUE(std::isnan(p->sigma));
  }
  const std::string w = AllWarnings(fit.result);
  EXPECT_NE(w.find("servo.Neck.* not determined: the neck never moved"), std::string::npos) << w;
  EXPECT_TRUE(IsDetermined(fit.result, "head.ipd_mm"));
  EXPECT_NEAR(fit.result.Find("head.ipd_mm")->value, truth.geometry.Ipd() * 1000, 0.5);
  EXPECT_FALSE(fit.result.Find("head.left.centre_x_mm")->determined);  // base origin gauge
  for (int s : {models::kRx, models::kRy, models::kLx, models::kLy})
    EXPECT_LT(evaluation::ServoMapRmsDeg(fit.head.servo_params[s].data(),
                                         truth.servo_params[s].data(),
                                         robot.servos[s].direction,
                                         robot.servos[s].min_us,
                                         robot.servos[s].max_us),
              0.1)
        << models::kServoNames[s];
}

TEST(FitHead, OneEyeOnlyNamesTheOtherEyeAndTheIpd) {
  std::mt19937_64 rng(9);
  const models::RobotConfig robot = models::DefaultRobotConfig();
  const models::HeadModel truth = PerturbedHead(robot, &rng);
  SyntheticHeadOptions so;
  so.steps_per_sweep = 4;
  so.grid_side = 3;
  SyntheticHeadData data = SynthesizeHeadViews(truth, robot, so, &rng);
  std::vector<calib::View> left;
  for (const calib::View& v : data.views)
    if (v.eye == models::kLeftEye) left.push_back(v);
  const HeadFit fit = FitHead(left, robot, InitialFor(robot, truth), HeadFitOptions());
  ASSERT_TRUE(fit.ok) << fit.message;
  EXPECT_FALSE(fit.result.Find("head.ipd_mm")->determined);
  EXPECT_NE(fit.result.Find("head.ipd_mm")->note.find("right eye"), std::string::npos)
      << fit.result.Find("head.ipd_mm")->note;
  EXPECT_FALSE(fit.result.Find("servo.Rx.deg_per_us")->determined);
  EXPECT_FALSE(fit.result.Find("head.right.mount_yaw_deg")->determined);
  EXPECT_TRUE(IsDetermined(fit.result, "servo.Lx.deg_per_us"));
  EXPECT_TRUE(HasWarning(fit.result, "servo.Rx.*", "not determined: no usable view of the right eye"))
      << AllWarnings(fit.result);
}

TEST(FitHead, OnePoseOnlyNamesEveryServoAndDoesNotCrash) {
  std::mt19937_64 rng(13);
  const models::RobotConfig robot = models::DefaultRobotConfig();
  const models::HeadModel truth = PerturbedHead(robot, &rng);
  SyntheticHeadData data = SynthesizeHeadViews(truth, robot, SyntheticHeadOptions(), &rng);
  std::vector<calib::View> one_pose;
  for (const calib::View& v : data.views)
    if (v.pwm_us == robot.Centre()) one_pose.push_back(v);
  ASSERT_FALSE(one_pose.empty());
  const HeadFit fit = FitHead(one_pose, robot, InitialFor(robot, truth), HeadFitOptions());
  for (int i = 0; i < kNumServos; ++i) {
    const Parameter* p = fit.result.Find(std::string("servo.") + models::kServoNames[i] + ".deg_per_us");
    ASSERT_NE(p, nullptr);
    EXPECT_FALSE(p->determined) << p->name;
    EXPECT_NE(p->note.find(i == kNeck ? "the neck never moved" : "one pulse width"), std::string::npos) << p->note;
  }
  // Eyes that never turn cannot separate the rotation centre from the camera offset.
  EXPECT_FALSE(fit.result.Find("head.ipd_mm")->determined);
  EXPECT_GT(fit.result.diagnostics["head"]["null_space_dimension"].get<int>(), 0);
  EXPECT_NE(AllWarnings(fit.result).find("null space"), std::string::npos) << AllWarnings(fit.result);
}

TEST(FitHead, NoViewsOrBadOptionsFailWithAMessage) {
  const models::RobotConfig robot = models::DefaultRobotConfig();
  const HeadFit none = FitHead({}, robot, models::NominalHeadModel(robot), HeadFitOptions());
  EXPECT_FALSE(none.ok);
  EXPECT_NE(none.message.find("no usable view"), std::string::npos);
  HeadFitOptions bad;
  bad.corner_sigma_px = -1;
  const HeadFit b = FitHead({}, robot, models::NominalHeadModel(robot), bad);
  EXPECT_FALSE(b.ok);
  EXPECT_NE(b.message.find("corner_sigma_px"), std::string::npos);
  // Too few corners: every view is dropped and named.
  calib::View tiny;
  tiny.frame_index = 4;
  tiny.target_id = "board";
  tiny.pwm_us = robot.Centre();
  for (int i = 0; i < 3; ++i) {
    tiny.corner_ids.push_back(i);
    tiny.pixels.emplace_back(300 + 10 * i, 200);
    tiny.points_in_target.emplace_back(0.04 * i, 0, 0);
  }
  const HeadFit few = FitHead({tiny}, robot, models::NominalHeadModel(robot), HeadFitOptions());
  EXPECT_FALSE(few.ok);
  EXPECT_NE(few.message.find("no usable view"), std::string::npos);
  EXPECT_TRUE(HasNote(few.result, "1 view with fewer than 6 corners dropped (board 1)", "(frame 4), 3 corners"))
      << AllWarnings(few.result);
  EXPECT_FALSE(HasWarning(few.result, "fewer than 6 corners", "")) << AllWarnings(few.result);
}

TEST(FitHead, RejectsGrossCornerOutliers) {
  std::mt19937_64 rng(21);
  const models::RobotConfig robot = models::DefaultRobotConfig();
  const models::HeadModel truth = PerturbedHead(robot, &rng);
  SyntheticHeadOptions so;
  so.steps_per_sweep = 4;
  so.grid_side = 3;
  SyntheticHeadData data = SynthesizeHeadViews(truth, robot, so, &rng);
  int corrupted = 0;
  for (size_t v = 0; v < data.views.size(); v += 7) {
    data.views[v].pixels[0] += Eigen::Vector2d(8.0, -6.0);
    ++corrupted;
  }
  const HeadFit fit = FitHead(data.views, robot, InitialFor(robot, truth), HeadFitOptions());
  ASSERT_TRUE(fit.ok) << fit.message;
  EXPECT_EQ(static_cast<int>(fit.outliers.size()), corrupted);
  for (const HeadOutlier& o : fit.outliers) EXPECT_GT(o.error_px, 5.0);
  EXPECT_NEAR(fit.result.Find("head.ipd_mm")->value, truth.geometry.Ipd() * 1000, 0.5);
}

}  // namespace
}  // namespace owlcal::fitting
