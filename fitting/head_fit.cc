#include "fitting/head_fit.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <ceres/ceres.h>
#include <ceres/manifold.h>
#include <ceres/product_manifold.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "fitting/head_residuals.h"
#include "models/servo_map.h"

namespace owlcal::fitting {
namespace {

using models::kLeftEye;
using models::kNeck;
using models::kNumServos;
using models::kRightEye;
using models::ServoMap;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kRadToDeg = 180.0 / M_PI;
constexpr const char* kServoParamNames[5] = {"centre_us", "deg_per_us", "quad_deg", "cubic_deg", "hysteresis_us"};
constexpr const char* kServoParamUnits[5] = {"us", "deg/us", "deg", "deg", "us"};

// One Ceres parameter block and how its entries are reported.
struct Block {
  std::vector<double> values;
  std::vector<std::string> names;   // report names per ambient entry (tangent names for poses)
  std::vector<double> scale;        // internal -> report unit
  std::vector<std::string> units;
  std::vector<bool> fixed;
  std::vector<std::string> fixed_note;
  bool is_pose = false;
  bool in_problem = false;

  double* data() { return values.data(); }
  int size() const { return static_cast<int>(values.size()); }
  bool AllFixed() const { return std::all_of(fixed.begin(), fixed.end(), [](bool f) { return f; }); }
  int TangentSize() const {
    if (is_pose) return 6;
    return static_cast<int>(std::count(fixed.begin(), fixed.end(), false));
  }
  // Ambient index of tangent index k (Euclidean blocks).
  int AmbientOfTangent(int k) const {
    int seen = 0;
    for (int i = 0; i < size(); ++i) {
      if (!fixed[i] && seen++ == k) return i;
    }
    return -1;
  }
  void Fix(int i, const std::string& note) {
    if (fixed[i]) return;  // keep the first (most specific) reason
    fixed[i] = true;
    fixed_note[i] = note;
  }
  void FixAll(const std::string& note) {
    for (int i = 0; i < size(); ++i) Fix(i, note);
  }
};

Block MakeBlock(const std::vector<double>& values,
                const std::vector<std::string>& names,
                const std::vector<double>& scale,
                const std::vector<std::string>& units) {
  Block b;
  b.values = values;
  b.names = names;
  b.scale = scale;
  b.units = units;
  b.fixed.assign(values.size(), false);
  b.fixed_note.assign(values.size(), "");
  return b;
}

// A view prepared for the residual: the data that survived filtering.
struct PreparedView {
  int index = 0;  // into the input views
  HeadViewCommand command;
  std::string target_id;
  std::vector<int> corner_ids;
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> pixels;
  std::vector<bool> inlier;
};

struct State {
  std::array<Block, kNumServos> servo;
  std::array<Block, 2> mount;
  Block centres;
  std::array<Block, 2> camera;
  std::map<std::string, Block> boards;
  models::DistortionModel camera_model[2];
  int width[2], height[2];
};

HeadViewCommand CommandOf(const calib::View& v, const models::RobotConfig& robot) {
  HeadViewCommand c;
  c.eye = v.eye;
  const int pan = models::kPanServo[v.eye], tilt = models::kTiltServo[v.eye];
  c.pan_us = v.pwm_us[pan];
  c.tilt_us = v.pwm_us[tilt];
  c.neck_us = v.pwm_us[kNeck];
  c.pan_direction = robot.servos[pan].direction;
  c.tilt_direction = robot.servos[tilt].direction;
  c.neck_direction = robot.servos[kNeck].direction;
  c.pan_approach = v.approach[pan];
  c.tilt_approach = v.approach[tilt];
  c.neck_approach = v.approach[kNeck];
  return c;
}

models::Rigid3d CamFromBase(State& s, const HeadViewCommand& c) {
  const int eye = c.eye;
  const double pan = ServoMap::JointAngle(s.servo[models::kPanServo[eye]].data(), c.pan_direction, c.pan_us, c.pan_approach);
  const double tilt =
      ServoMap::JointAngle(s.servo[models::kTiltServo[eye]].data(), c.tilt_direction, c.tilt_us, c.tilt_approach);
  const double neck = ServoMap::JointAngle(s.servo[kNeck].data(), c.neck_direction, c.neck_us, c.neck_approach);
  double centre[3];
  EyeCentreOfCentres(s.centres.data(), eye, centre);
  return CamFromEyeOfMount(s.mount[eye].data()) * models::HeadFromEye(centre, pan, tilt).Inverse() *
         models::HeadFromBase(neck);
}

// Whitened per-corner errors [px] of a view at the current state (double evaluation).
std::vector<double> CornerErrorsPx(State& s, const PreparedView& v) {
  const models::Rigid3d cam_from_target = CamFromBase(s, v.command) * models::Rigid3d::Map(s.boards.at(v.target_id).data());
  std::vector<double> err(v.pixels.size(), kNaN);
  models::CameraIntrinsics cam;
  cam.model = s.camera_model[v.command.eye];
  cam.params = s.camera[v.command.eye].values;
  for (size_t i = 0; i < v.pixels.size(); ++i) {
    const Eigen::Vector3d p = cam_from_target * v.points[i];
    Eigen::Vector2d px;
    if (cam.Project(p.data(), px.data())) err[i] = (px - v.pixels[i]).norm();
  }
  return err;
}

// Builds the problem over the inlier corners. Returns the number of corners used.
int BuildProblem(State& s,
                 const std::vector<PreparedView>& views,
                 double sigma_px,
                 double huber_k,
                 const HeadFitOptions& options,
                 int max_corners_per_view,
                 ceres::Problem* problem) {
  int num_corners = 0;
  for (const PreparedView& v : views) {
    const int eye = v.command.eye;
    const int stride = max_corners_per_view > 0
                           ? std::max<int>(1, static_cast<int>(v.pixels.size()) / max_corners_per_view)
                           : 1;
    Block& board = s.boards.at(v.target_id);
    double* blocks[7] = {s.servo[models::kPanServo[eye]].data(),
                         s.servo[models::kTiltServo[eye]].data(),
                         s.servo[kNeck].data(),
                         s.mount[eye].data(),
                         s.centres.data(),
                         board.data(),
                         s.camera[eye].data()};
    ceres::CostFunction* cost = models::VisitCameraModel(s.camera_model[eye], [&]<typename Camera>() -> ceres::CostFunction* {
      auto* f = new HeadViewResidual<Camera>;
      f->command = v.command;
      f->sigma_px = sigma_px;
      f->huber_k = huber_k;
      for (size_t i = 0; i < v.pixels.size(); ++i) {
        if (!v.inlier[i] || i % stride != 0) continue;
        f->points_in_target.push_back(v.points[i]);
        f->pixels.push_back(v.pixels[i]);
      }
      if (f->pixels.empty()) {
        delete f;
        return nullptr;
      }
      num_corners += static_cast<int>(f->pixels.size());
      return new ceres::AutoDiffCostFunction<HeadViewResidual<Camera>, ceres::DYNAMIC, ServoMap::kNumParams,
                                             ServoMap::kNumParams, ServoMap::kNumParams, kMountParams,
                                             kCentresParams, 7, Camera::kNumParams>(f, f->NumResiduals());
    });
    if (cost == nullptr) continue;
    problem->AddResidualBlock(cost, nullptr, blocks[0], blocks[1], blocks[2], blocks[3], blocks[4], blocks[5], blocks[6]);
  }
  // Priors on the intrinsics.
  for (int e = 0; e < 2; ++e) {
    if (!options.fit_intrinsics || !options.intrinsics_prior_covariance[e]) continue;
    if (!problem->HasParameterBlock(s.camera[e].data())) continue;
    const Eigen::MatrixXd& cov = *options.intrinsics_prior_covariance[e];
    const int n = s.camera[e].size();
    Eigen::MatrixXd info = cov.inverse();
    Eigen::LLT<Eigen::MatrixXd> llt(info);
    const Eigen::MatrixXd upper = llt.matrixU();
    auto add_prior = [&]<int N>() {
      auto* f = new GaussianPriorResidual<N>;
      f->mean = Eigen::Map<const Eigen::Matrix<double, N, 1>>(s.camera[e].data());
      f->sqrt_information = upper;
      problem->AddResidualBlock(new ceres::AutoDiffCostFunction<GaussianPriorResidual<N>, N, N>(f), nullptr,
                                s.camera[e].data());
    };
    if (n == 9) add_prior.template operator()<9>();
    if (n == 12) add_prior.template operator()<12>();
  }
  // Manifolds and what is held.
  auto configure = [&](Block& b) {
    b.in_problem = problem->HasParameterBlock(b.data());
    if (!b.in_problem) return;
    if (b.is_pose) {
      problem->SetManifold(b.data(),
                           new ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>>());
      return;
    }
    if (b.AllFixed()) {
      problem->SetParameterBlockConstant(b.data());
      return;
    }
    std::vector<int> held;
    for (int i = 0; i < b.size(); ++i) {
      if (b.fixed[i]) held.push_back(i);
    }
    if (!held.empty()) problem->SetManifold(b.data(), new ceres::SubsetManifold(b.size(), held));
  };
  for (Block& b : s.servo) configure(b);
  for (Block& b : s.mount) configure(b);
  configure(s.centres);
  for (Block& b : s.camera) configure(b);
  for (auto& [id, b] : s.boards) configure(b);
  return num_corners;
}

ceres::Solver::Summary Solve(ceres::Problem* problem, const HeadFitOptions& options, double tolerance) {
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  so.max_num_iterations = options.max_iterations;
  so.num_threads = options.num_threads;
  so.function_tolerance = tolerance;
  so.gradient_tolerance = tolerance * 1e-2;
  so.parameter_tolerance = tolerance;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, problem, &summary);
  return summary;
}

std::string JoinNames(const std::vector<std::string>& names) {
  // Compress servo.X.<all five> into servo.X.*.
  std::map<std::string, int> servo_count;
  for (const std::string& n : names) {
    if (n.rfind("servo.", 0) == 0) servo_count[n.substr(0, n.rfind('.'))]++;
  }
  std::vector<std::string> out;
  std::set<std::string> done;
  for (const std::string& n : names) {
    if (n.rfind("servo.", 0) == 0) {
      const std::string prefix = n.substr(0, n.rfind('.'));
      if (servo_count[prefix] == 5) {
        if (done.insert(prefix).second) out.push_back(prefix + ".*");
        continue;
      }
    }
    out.push_back(n);
  }
  std::string s;
  for (size_t i = 0; i < out.size(); ++i) s += (i ? ", " : "") + out[i];
  return s;
}

}  // namespace

bool HeadFitOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = "HeadFitOptions: " + m;
    return false;
  };
  if (!(corner_sigma_px > 0)) return fail("corner_sigma_px = " + std::to_string(corner_sigma_px) + " must be > 0");
  if (huber_sigma < 0) return fail("huber_sigma = " + std::to_string(huber_sigma) + " must be >= 0");
  if (outlier_threshold_sigma < 0)
    return fail("outlier_threshold_sigma = " + std::to_string(outlier_threshold_sigma) + " must be >= 0");
  if (min_corners_per_view < 3)
    return fail("min_corners_per_view = " + std::to_string(min_corners_per_view) + " must be >= 3");
  if (max_iterations < 1) return fail("max_iterations = " + std::to_string(max_iterations) + " must be >= 1");
  if (!(rank_tolerance > 0 && rank_tolerance < 1))
    return fail("rank_tolerance = " + std::to_string(rank_tolerance) + " must be in (0, 1)");
  if (num_threads < 1) return fail("num_threads = " + std::to_string(num_threads) + " must be >= 1");
  return true;
}

HeadFit FitHead(const std::vector<calib::View>& views,
                const models::RobotConfig& robot,
                const models::HeadModel& initial,
                const HeadFitOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  HeadFit fit;
  CalibrationResult& result = fit.result;
  nlohmann::json timing = nlohmann::json::object();
  auto mark = [&, last = t0](const char* stage) mutable {
    const auto now = std::chrono::steady_clock::now();
    timing[stage] = std::chrono::duration<double>(now - last).count();
    last = now;
  };
  result.summaries.push_back({});
  SolveSummary& summary = result.summaries.back();
  summary.problem = "head";
  auto fail = [&](const std::string& message) {
    fit.ok = false;
    fit.message = message;
    summary.message = message;
    summary.usable = false;
    result.warnings.push_back(message);
    return fit;
  };
  std::string why;
  if (!options.Check(&why)) return fail(why);
  for (int e = 0; e < 2; ++e) {
    const auto& c = initial.intrinsics[e];
    if (static_cast<int>(c.params.size()) != 4 + c.NumDistortion())
      return fail(std::string("initial head: ") + models::kEyeNames[e] + " camera params has " +
                  std::to_string(c.params.size()) + " values, model needs " + std::to_string(4 + c.NumDistortion()));
  }

  // ---- Views: validate and filter.
  std::vector<PreparedView> prepared;
  for (size_t i = 0; i < views.size(); ++i) {
    const calib::View& v = views[i];
    const std::string where = "view " + std::to_string(i) + " (frame " + std::to_string(v.frame_index) + ")";
    if (v.eye != kLeftEye && v.eye != kRightEye) {
      result.warnings.push_back(where + ": eye = " + std::to_string(v.eye) + " is not 0 or 1; dropped");
      continue;
    }
    if (v.pixels.size() != v.points_in_target.size()) {
      result.warnings.push_back(where + ": " + std::to_string(v.pixels.size()) + " pixels but " +
                                std::to_string(v.points_in_target.size()) + " target points; dropped");
      continue;
    }
    if (static_cast<int>(v.pixels.size()) < options.min_corners_per_view) {
      result.warnings.push_back(where + ": " + std::to_string(v.pixels.size()) + " corners < " +
                                std::to_string(options.min_corners_per_view) + "; dropped");
      continue;
    }
    PreparedView p;
    p.index = static_cast<int>(i);
    p.command = CommandOf(v, robot);
    p.target_id = v.target_id;
    p.corner_ids = v.corner_ids;
    p.corner_ids.resize(v.pixels.size(), -1);
    p.points = v.points_in_target;
    p.pixels = v.pixels;
    p.inlier.assign(v.pixels.size(), true);
    prepared.push_back(std::move(p));
  }
  if (prepared.empty())
    return fail("head fit: no usable view (" + std::to_string(views.size()) + " given); nothing can be determined");

  // ---- Initial state from `initial`; neck centre and directions from the robot file.
  State s;
  for (int i = 0; i < kNumServos; ++i) {
    std::vector<double> p(initial.servo_params[i].begin(), initial.servo_params[i].end());
    if (i == kNeck) p[0] = robot.servos[kNeck].centre_us;
    std::vector<std::string> names;
    for (const char* n : kServoParamNames) names.push_back(std::string("servo.") + models::kServoNames[i] + "." + n);
    s.servo[i] = MakeBlock(p, names, {1, 1, 1, 1, 1},
                           std::vector<std::string>(kServoParamUnits, kServoParamUnits + 5));
  }
  for (int e = 0; e < 2; ++e) {
    const std::string eye = models::kEyeNames[e];
    const Eigen::Matrix3d r = initial.geometry.cam_from_eye[e].rotation.toRotationMatrix();
    const Eigen::Vector3d t = initial.geometry.cam_from_eye[e].translation;
    const double yaw = std::asin(std::clamp(-r(2, 0), -1.0, 1.0));
    const double roll = std::atan2(r(1, 0), r(0, 0));
    s.mount[e] = MakeBlock({roll, yaw, t.x(), t.y(), t.z()},
                           {"head." + eye + ".mount_roll_deg", "head." + eye + ".mount_yaw_deg",
                            "head." + eye + ".mount_x_mm", "head." + eye + ".mount_y_mm", "head." + eye + ".mount_z_mm"},
                           {kRadToDeg, kRadToDeg, 1000, 1000, 1000}, {"deg", "deg", "mm", "mm", "mm"});
    s.camera_model[e] = initial.intrinsics[e].model;
    s.width[e] = initial.intrinsics[e].width;
    s.height[e] = initial.intrinsics[e].height;
    std::vector<std::string> names, units;
    const char* base_names[] = {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"};
    for (size_t k = 0; k < initial.intrinsics[e].params.size(); ++k) {
      names.push_back("head." + eye + "." + base_names[k]);
      units.push_back(k < 4 ? "px" : "");
    }
    s.camera[e] = MakeBlock(initial.intrinsics[e].params, names, std::vector<double>(names.size(), 1.0), units);
  }
  const Eigen::Vector3d cl = initial.geometry.centre_in_head[kLeftEye], cr = initial.geometry.centre_in_head[kRightEye];
  s.centres = MakeBlock({cl.x(), cl.y(), cl.z(), cr.x(), cr.y()},
                        {"head.left.centre_x_mm", "head.left.centre_y_mm", "head.left.centre_z_mm",
                         "head.right.centre_x_mm", "head.right.centre_y_mm"},
                        {1000, 1000, 1000, 1000, 1000}, {"mm", "mm", "mm", "mm", "mm"});

  // ---- What the data can determine, decided from the data before the solve.
  int views_per_eye[2] = {0, 0};
  std::array<std::set<int>, kNumServos> pwm_seen;
  std::array<std::set<int>, kNumServos> approach_seen;
  std::set<std::string> targets;
  for (const PreparedView& p : prepared) {
    const calib::View& v = views[p.index];
    views_per_eye[v.eye]++;
    targets.insert(v.target_id);
    for (int servo : {int(models::kPanServo[v.eye]), int(models::kTiltServo[v.eye]), int(kNeck)}) {
      pwm_seen[servo].insert(v.pwm_us[servo]);
      if (v.approach[servo] != 0) approach_seen[servo].insert(v.approach[servo]);
    }
  }
  for (int e = 0; e < 2; ++e) {
    if (views_per_eye[e] > 0) continue;
    const std::string note = std::string("not determined: no usable view of the ") + models::kEyeNames[e] + " eye";
    s.servo[models::kPanServo[e]].FixAll(note);
    s.servo[models::kTiltServo[e]].FixAll(note);
    s.mount[e].FixAll(note);
    s.camera[e].FixAll(note);
    if (e == kLeftEye) {
      s.centres.Fix(0, note);
      s.centres.Fix(1, note);
    } else {
      s.centres.Fix(3, note);
      s.centres.Fix(4, note);
    }
  }
  const bool neck_moved = pwm_seen[kNeck].size() > 1;
  if (!neck_moved) {
    s.servo[kNeck].FixAll("not determined: the neck never moved (" +
                          (pwm_seen[kNeck].empty() ? std::string("no view") : std::to_string(*pwm_seen[kNeck].begin()) + " us") +
                          " in every view)");
  }
  s.servo[kNeck].Fix(0, "fixed at the robot file's centre " + std::to_string(robot.servos[kNeck].centre_us) +
                            " us: the neck's zero only turns the base frame, which no board observation sees (gauge)");
  for (int i = 0; i < kNumServos; ++i) {
    Block& b = s.servo[i];
    const std::string name = models::kServoNames[i];
    const size_t distinct = pwm_seen[i].size();
    if (distinct == 1) {
      b.FixAll("not determined: " + name + " took one pulse width only (" + std::to_string(*pwm_seen[i].begin()) + " us)");
    } else if (distinct == 2) {
      b.Fix(2, "not determined: " + name + " took only 2 distinct pulse widths");
      b.Fix(3, "not determined: " + name + " took only 2 distinct pulse widths");
    } else if (distinct == 3) {
      b.Fix(3, "not determined: " + name + " took only 3 distinct pulse widths");
    }
    if (approach_seen[i].size() < 2)
      b.Fix(4, "not determined: " + name + " was never approached from both directions (held at " +
                   std::to_string(b.values[4]) + " us)");
    if (!options.fit_nonlinear) {
      b.Fix(2, "held at " + std::to_string(b.values[2]) + " by option fit_nonlinear = false");
      b.Fix(3, "held at " + std::to_string(b.values[3]) + " by option fit_nonlinear = false");
    }
    if (!options.fit_hysteresis) b.Fix(4, "held at " + std::to_string(b.values[4]) + " us by option fit_hysteresis = false");
  }
  if (neck_moved) {
    s.centres.Fix(1, "fixed at " + std::to_string(cl.y() * 1000) +
                         " mm: the base frame's height along the neck axis is a gauge (boards move with it)");
  } else {
    for (int k = 0; k < 3; ++k)
      s.centres.Fix(k, "fixed at the initial value: without neck motion the base origin is a gauge (boards move with it)");
  }
  if (!options.fit_intrinsics) {
    for (int e = 0; e < 2; ++e) s.camera[e].FixAll("held at the given intrinsics (fit_intrinsics = false)");
  }

  // ---- Board poses: PnP on the view with the most corners, chained through the initial head.
  for (const std::string& id : targets) {
    const PreparedView* best = nullptr;
    for (const PreparedView& p : prepared) {
      if (p.target_id == id && (!best || p.pixels.size() > best->pixels.size())) best = &p;
    }
    const int eye = best->command.eye;
    std::vector<cv::Point3d> obj;
    std::vector<cv::Point2d> img;
    for (size_t i = 0; i < best->pixels.size(); ++i) {
      obj.emplace_back(best->points[i].x(), best->points[i].y(), best->points[i].z());
      img.emplace_back(best->pixels[i].x(), best->pixels[i].y());
    }
    const std::vector<double>& cp = s.camera[eye].values;
    cv::Matx33d k(cp[0], 0, cp[2], 0, cp[1], cp[3], 0, 0, 1);
    std::vector<double> dist(cp.begin() + 4, cp.end());
    cv::Mat rvec, tvec;
    bool ok = false;
    try {
      ok = cv::solvePnP(obj, img, k, dist, rvec, tvec, false, cv::SOLVEPNP_ITERATIVE);
    } catch (const cv::Exception& e) {
      ok = false;
    }
    if (!ok || tvec.at<double>(2) <= 0) {
      result.warnings.push_back("target '" + id + "': PnP failed on frame " + std::to_string(views[best->index].frame_index) +
                                "; its views are dropped");
      continue;
    }
    cv::Matx33d rm;
    cv::Rodrigues(rvec, rm);
    Eigen::Matrix3d r;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) r(a, b) = rm(a, b);
    const models::Rigid3d cam_from_target(Eigen::Quaterniond(r),
                                          Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2)));
    const models::Rigid3d base_from_target = CamFromBase(s, best->command).Inverse() * cam_from_target;
    Block b;
    b.values.resize(7);
    base_from_target.ToArray(b.values.data());
    b.is_pose = true;
    for (const char* c : {"rot_x", "rot_y", "rot_z", "x", "y", "z"}) b.names.push_back("board." + id + "." + c);
    b.fixed.assign(7, false);
    b.fixed_note.assign(7, "");
    s.boards.emplace(id, std::move(b));
  }
  prepared.erase(std::remove_if(prepared.begin(), prepared.end(),
                                [&](const PreparedView& p) { return !s.boards.count(p.target_id); }),
                 prepared.end());
  if (prepared.empty()) return fail("head fit: no board pose could be initialised (PnP failed for every target)");

  // ---- Stage 1: robust solve; reject outliers; stage 2: plain solve for the covariance.
  const double sigma = options.corner_sigma_px;
  int iterations = 0;
  double initial_cost = 0;
  {
    ceres::Problem problem;
    // Every corner is not needed to reach the basin: a spread subset per view is 3-5 x faster.
    BuildProblem(s, prepared, sigma, options.huber_sigma, options, 12, &problem);
    // Loose tolerance: this stage only has to find the basin and the outliers.
    const ceres::Solver::Summary s1 = Solve(&problem, options, 1e-7);
    iterations += s1.iterations.size();
    initial_cost = s1.initial_cost;
  }
  mark("solve_robust_s");
  if (options.outlier_threshold_sigma > 0) {
    for (PreparedView& p : prepared) {
      const std::vector<double> err = CornerErrorsPx(s, p);
      for (size_t i = 0; i < err.size(); ++i) {
        if (!std::isfinite(err[i]) || err[i] > options.outlier_threshold_sigma * sigma) {
          p.inlier[i] = false;
          const calib::View& v = views[p.index];
          fit.outliers.push_back({v.frame_index, v.eye, v.target_id, p.corner_ids[i], err[i]});
        }
      }
    }
  }
  ceres::Problem problem;
  fit.num_corners_used = BuildProblem(s, prepared, sigma, 0.0, options, 0, &problem);
  const ceres::Solver::Summary s2 = Solve(&problem, options, 1e-12);
  iterations += s2.iterations.size();
  mark("solve_final_s");
  // Blocks the problem does not contain are not determined by anything.
  auto mark_unused = [](Block& b, const std::string& what) {
    if (!b.in_problem) b.FixAll("not determined: no usable view involves " + what);
  };
  for (int i = 0; i < kNumServos; ++i) mark_unused(s.servo[i], std::string("servo ") + models::kServoNames[i]);
  for (int e = 0; e < 2; ++e) {
    mark_unused(s.mount[e], std::string("the ") + models::kEyeNames[e] + " camera");
    mark_unused(s.camera[e], std::string("the ") + models::kEyeNames[e] + " camera");
  }

  // ---- Residual statistics.
  double sum_sq = 0;
  int n_corners = 0;
  nlohmann::json per_view = nlohmann::json::array();
  for (const PreparedView& p : prepared) {
    const std::vector<double> err = CornerErrorsPx(s, p);
    double vs = 0;
    int vn = 0;
    for (size_t i = 0; i < err.size(); ++i) {
      if (!p.inlier[i] || !std::isfinite(err[i])) continue;
      vs += err[i] * err[i];
      ++vn;
    }
    sum_sq += vs;
    n_corners += vn;
    const calib::View& v = views[p.index];
    per_view.push_back({{"frame", v.frame_index}, {"eye", models::kEyeNames[v.eye]}, {"target", v.target_id},
                        {"corners", vn}, {"rms_px", vn ? std::sqrt(vs / vn) : 0.0}});
  }
  fit.num_views_used = static_cast<int>(prepared.size());
  const double rms = n_corners ? std::sqrt(sum_sq / n_corners) : 0.0;
  // Per-axis noise estimate vs the sigma used for whitening.
  const double noise_factor = n_corners ? rms / (std::sqrt(2.0) * sigma) : 0.0;

  // ---- Observability: null space of the column-scaled J^T J over every free block.
  std::vector<Block*> free_blocks;
  for (Block& b : s.servo) free_blocks.push_back(&b);
  for (Block& b : s.mount) free_blocks.push_back(&b);
  free_blocks.push_back(&s.centres);
  for (Block& b : s.camera) free_blocks.push_back(&b);
  const size_t num_head_blocks = free_blocks.size();
  for (auto& [id, b] : s.boards) free_blocks.push_back(&b);
  std::vector<Block*> eval_blocks;   // non-constant, in the problem
  std::vector<int> offsets;
  int n = 0;
  size_t num_head_eval = 0;
  for (size_t i = 0; i < free_blocks.size(); ++i) {
    Block* b = free_blocks[i];
    if (!b->in_problem || (!b->is_pose && b->AllFixed())) continue;
    eval_blocks.push_back(b);
    offsets.push_back(n);
    n += b->TangentSize();
    if (i < num_head_blocks) num_head_eval = eval_blocks.size();
  }
  int head_dim = 0;
  for (size_t i = 0; i < num_head_eval; ++i) head_dim += eval_blocks[i]->TangentSize();
  // Tangent index -> (block, ambient index) names.
  std::vector<std::string> tangent_names(n);
  for (size_t bi = 0; bi < eval_blocks.size(); ++bi) {
    Block* b = eval_blocks[bi];
    for (int k = 0; k < b->TangentSize(); ++k)
      tangent_names[offsets[bi] + k] = b->is_pose ? b->names[k] : b->names[b->AmbientOfTangent(k)];
  }
  Eigen::MatrixXd cov_tangent = Eigen::MatrixXd::Zero(n, n);
  std::vector<bool> null_param(n, false);
  std::vector<std::string> null_note(n);
  std::string covariance_source;
  int null_dim = 0;
  if (n > 0) {
    ceres::Problem::EvaluateOptions eo;
    for (Block* b : eval_blocks) eo.parameter_blocks.push_back(b->data());
    eo.apply_loss_function = false;
    ceres::CRSMatrix jac;
    problem.Evaluate(eo, nullptr, nullptr, nullptr, &jac);
    Eigen::MatrixXd h = Eigen::MatrixXd::Zero(n, n);
    for (int r = 0; r < jac.num_rows; ++r) {
      for (int a = jac.rows[r]; a < jac.rows[r + 1]; ++a) {
        const double va = jac.values[a];
        const int ca = jac.cols[a];
        for (int b = a; b < jac.rows[r + 1]; ++b) h(ca, jac.cols[b]) += va * jac.values[b];
      }
    }
    h = h.selfadjointView<Eigen::Upper>();
    mark("information_matrix_s");
    Eigen::VectorXd d(n);
    for (int i = 0; i < n; ++i) d(i) = h(i, i) > 0 ? std::sqrt(h(i, i)) : 1.0;
    const Eigen::MatrixXd hs = d.asDiagonal().inverse() * h * d.asDiagonal().inverse();
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(hs);
    const Eigen::VectorXd& lambda = eig.eigenvalues();
    const double lmax = std::max(lambda.maxCoeff(), 1e-300);
    Eigen::MatrixXd cs = Eigen::MatrixXd::Zero(n, n);
    for (int k = 0; k < n; ++k) {
      const Eigen::VectorXd v = eig.eigenvectors().col(k);
      if (lambda(k) > options.rank_tolerance * lmax) {
        cs += v * v.transpose() / lambda(k);
        continue;
      }
      ++null_dim;
      std::vector<std::string> involved;
      std::vector<int> idx;
      const double vmax = v.cwiseAbs().maxCoeff();
      for (int i = 0; i < n; ++i) {
        if (std::abs(v(i)) >= 0.2 * vmax) {
          idx.push_back(i);
          involved.push_back(tangent_names[i]);
        }
      }
      for (int i : idx) {
        null_param[i] = true;
        std::vector<std::string> others;
        for (const std::string& o : involved)
          if (o != tangent_names[i]) others.push_back(o);
        if (null_note[i].empty())
          null_note[i] = others.empty() ? "not determined: no observation constrains it (Jacobian column is zero)"
                                        : "not determined: the data cannot separate it from " + JoinNames(others) +
                                              " (null space of the Jacobian)";
      }
    }
    for (int i = 0; i < n; ++i)
      if (h(i, i) <= 0) {
        null_param[i] = true;
        null_note[i] = "not determined: no observation constrains it (Jacobian column is zero)";
      }
    cov_tangent = d.asDiagonal().inverse() * cs * d.asDiagonal().inverse();
    covariance_source = null_dim ? "pseudo-inverse of J^T J on the determined subspace (rank deficient by " +
                                       std::to_string(null_dim) + ")"
                                 : "pseudo-inverse of J^T J";
    mark("rank_analysis_s");
    // Full rank: the head blocks' covariance from ceres::Covariance (boards marginalised).
    if (null_dim == 0 && num_head_eval > 0) {
      ceres::Covariance::Options co;
      co.num_threads = options.num_threads;
      co.apply_loss_function = false;
      ceres::Covariance covariance(co);
      std::vector<std::pair<const double*, const double*>> pairs;
      std::vector<const double*> head_blocks;
      for (size_t i = 0; i < num_head_eval; ++i) head_blocks.push_back(eval_blocks[i]->data());
      for (size_t i = 0; i < head_blocks.size(); ++i)
        for (size_t j = i; j < head_blocks.size(); ++j) pairs.emplace_back(head_blocks[i], head_blocks[j]);
      if (covariance.Compute(pairs, &problem)) {
        Eigen::MatrixXd c(head_dim, head_dim);
        if (covariance.GetCovarianceMatrixInTangentSpace(head_blocks, c.data())) {
          // Row-major from Ceres; symmetric, so the layout does not matter.
          cov_tangent.topLeftCorner(head_dim, head_dim) = c;
          covariance_source = "ceres::Covariance";
        }
      }
    }
  }

  mark("covariance_s");
  // ---- Outputs: head model, parameters, covariance.
  models::HeadModel head = initial;
  for (int i = 0; i < kNumServos; ++i) {
    std::copy_n(s.servo[i].values.begin(), 5, head.servo_params[i].begin());
    head.directions[i] = robot.servos[i].direction;
  }
  for (int e = 0; e < 2; ++e) {
    double c[3];
    EyeCentreOfCentres(s.centres.data(), e, c);
    head.geometry.centre_in_head[e] = Eigen::Vector3d(c[0], c[1], c[2]);
    head.geometry.cam_from_eye[e] = CamFromEyeOfMount(s.mount[e].data());
    head.intrinsics[e].params = s.camera[e].values;
  }
  fit.head = head;
  result.head = head;
  for (auto& [id, b] : s.boards) fit.base_from_target[id] = models::Rigid3d::Map(b.data());

  // Tangent index of each (block, ambient) for the head blocks.
  std::map<std::pair<const Block*, int>, int> tangent_of;
  for (size_t bi = 0; bi < num_head_eval; ++bi) {
    const Block* b = eval_blocks[bi];
    for (int k = 0; k < b->TangentSize(); ++k) tangent_of[{b, b->AmbientOfTangent(k)}] = offsets[bi] + k;
  }
  // Flat covariance in report units over the free, determined head parameters.
  std::vector<int> flat_tangent;
  std::vector<double> flat_scale;
  auto add_block_params = [&](const Block& b, bool report) {
    for (int i = 0; i < b.size(); ++i) {
      Parameter p;
      p.name = b.names[i];
      p.value = b.values[i] * b.scale[i];
      p.unit = b.units[i];
      auto it = tangent_of.find({&b, i});
      if (b.fixed[i] || it == tangent_of.end()) {
        p.determined = false;
        p.sigma = kNaN;
        p.note = b.fixed_note[i].empty() ? "not determined" : b.fixed_note[i];
      } else if (null_param[it->second]) {
        p.determined = false;
        p.sigma = kNaN;
        p.note = null_note[it->second];
      } else {
        p.sigma = std::sqrt(std::max(0.0, cov_tangent(it->second, it->second))) * b.scale[i];
        fit.param_names.push_back(p.name);
        flat_tangent.push_back(it->second);
        flat_scale.push_back(b.scale[i]);
      }
      if (report) result.Set(p);
    }
  };
  for (const Block& b : s.servo) add_block_params(b, true);
  add_block_params(s.centres, true);
  for (int e = 0; e < 2; ++e) {
    add_block_params(s.mount[e], true);
    add_block_params(s.camera[e], options.fit_intrinsics);
  }
  // Derived: right centre z (= left z), mount pitch (gauge), IPD with its sigma.
  {
    const Parameter* lz = result.Find("head.left.centre_z_mm");
    Parameter rz = *lz;
    rz.name = "head.right.centre_z_mm";
    rz.note = "equal to head.left.centre_z_mm by convention (head yaw gauge: x axis along the eye baseline)" +
              (lz->note.empty() ? std::string() : "; " + lz->note);
    result.Set(rz);
    for (int e = 0; e < 2; ++e) {
      Parameter pitch;
      pitch.name = std::string("head.") + models::kEyeNames[e] + ".mount_pitch_deg";
      pitch.value = 0;
      pitch.sigma = kNaN;
      pitch.unit = "deg";
      pitch.determined = false;
      pitch.note = "fixed at 0: a mount pitch is exactly a tilt offset, absorbed by the tilt servo's centre (gauge)";
      result.Set(pitch);
    }
    Parameter ipd;
    ipd.name = "head.ipd_mm";
    ipd.unit = "mm";
    ipd.value = head.geometry.Ipd() * 1000;
    const Eigen::Vector3d dv = head.geometry.centre_in_head[kRightEye] - head.geometry.centre_in_head[kLeftEye];
    // d ipd / d [lx ly lz rx ry] (m per m).
    const double g[5] = {-dv.x() / dv.norm(), -dv.y() / dv.norm(), 0, dv.x() / dv.norm(), dv.y() / dv.norm()};
    bool determined = true;
    std::string note;
    double var = 0;
    for (int a = 0; a < 5; ++a) {
      if (a == 2) continue;
      auto ia = tangent_of.find({&s.centres, a});
      const bool gauge_fixed = s.centres.fixed[a] && s.centres.fixed_note[a].find("gauge") != std::string::npos;
      if (ia == tangent_of.end()) {
        if (gauge_fixed) continue;  // a gauge choice does not change the IPD
        determined = false;
        note = "not determined: " + s.centres.names[a] + " " + s.centres.fixed_note[a];
        continue;
      }
      if (null_param[ia->second]) {
        determined = false;
        note = "not determined: " + s.centres.names[a] + " " + null_note[ia->second];
        continue;
      }
      for (int b = 0; b < 5; ++b) {
        auto ib = tangent_of.find({&s.centres, b});
        if (b == 2 || ib == tangent_of.end()) continue;
        var += g[a] * g[b] * cov_tangent(ia->second, ib->second);
      }
    }
    ipd.determined = determined;
    ipd.sigma = determined ? std::sqrt(std::max(var, 0.0)) * 1000 : kNaN;
    ipd.note = note;
    result.Set(ipd);
  }
  const int nf = static_cast<int>(flat_tangent.size());
  fit.covariance.resize(nf, nf);
  for (int a = 0; a < nf; ++a)
    for (int b = 0; b < nf; ++b)
      fit.covariance(a, b) = cov_tangent(flat_tangent[a], flat_tangent[b]) * flat_scale[a] * flat_scale[b];

  // Undetermined list and grouped warnings.
  std::map<std::string, std::vector<std::string>> by_note;
  for (const Parameter& p : result.parameters) {
    if (p.determined) continue;
    fit.undetermined.push_back(p.name + ": " + p.note);
    if (p.note.rfind("not determined", 0) == 0) by_note[p.note].push_back(p.name);
  }
  for (const auto& [note, names] : by_note) result.warnings.push_back(JoinNames(names) + " " + note);
  if (noise_factor > 1.5)
    result.warnings.push_back("corner errors are " + std::to_string(noise_factor) +
                              " x corner_sigma_px: the model does not fit or the noise is larger; sigmas are too small");

  // ---- Summary and diagnostics.
  summary.termination = ceres::TerminationTypeToString(s2.termination_type);
  summary.message = s2.message;
  summary.initial_cost = initial_cost;
  summary.final_cost = s2.final_cost;
  summary.iterations = iterations;
  summary.rms_px = rms;
  summary.num_residuals = 2 * n_corners;
  summary.num_outliers = static_cast<int>(fit.outliers.size());
  summary.usable = s2.IsSolutionUsable();
  summary.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  result.diagnostics["head"] = {{"per_view", per_view},
                                {"num_views", fit.num_views_used},
                                {"num_corners", n_corners},
                                {"noise_factor", noise_factor},
                                {"null_space_dimension", null_dim},
                                {"covariance_source", covariance_source},
                                {"timing", timing}};
  nlohmann::json outliers = nlohmann::json::array();
  for (size_t i = 0; i < fit.outliers.size() && i < 200; ++i) {
    const HeadOutlier& o = fit.outliers[i];
    outliers.push_back({{"frame", o.frame_index}, {"eye", models::kEyeNames[o.eye]}, {"target", o.target_id},
                        {"corner", o.corner_id}, {"error_px", std::isfinite(o.error_px) ? o.error_px : -1.0}});
  }
  result.diagnostics["head"]["outliers"] = outliers;
  nlohmann::json boards = nlohmann::json::object();
  for (const auto& [id, pose] : fit.base_from_target) {
    double a[7];
    pose.ToArray(a);
    boards[id] = std::vector<double>(a, a + 7);
  }
  result.diagnostics["head"]["base_from_target"] = boards;
  result.inputs["head_fit"] = {{"corner_sigma_px", sigma},
                               {"fit_intrinsics", options.fit_intrinsics},
                               {"fit_nonlinear", options.fit_nonlinear},
                               {"fit_hysteresis", options.fit_hysteresis},
                               {"huber_sigma", options.huber_sigma},
                               {"outlier_threshold_sigma", options.outlier_threshold_sigma},
                               {"num_views_given", views.size()}};
  fit.ok = summary.usable;
  fit.message = summary.usable ? "head fit: " + std::to_string(fit.num_views_used) + " views, " +
                                     std::to_string(n_corners) + " corners, RMS " + std::to_string(rms) + " px"
                               : "head fit: solver failed: " + s2.message;
  return fit;
}

std::vector<Parameter> HeadParameters(const models::HeadModel& head, bool with_intrinsics) {
  std::vector<Parameter> out;
  auto add = [&](const std::string& name, double value, const std::string& unit) {
    Parameter p;
    p.name = name;
    p.value = value;
    p.unit = unit;
    out.push_back(p);
  };
  for (int i = 0; i < kNumServos; ++i)
    for (int k = 0; k < 5; ++k)
      add(std::string("servo.") + models::kServoNames[i] + "." + kServoParamNames[k], head.servo_params[i][k],
          kServoParamUnits[k]);
  add("head.ipd_mm", head.geometry.Ipd() * 1000, "mm");
  const char* const axes[3] = {"x", "y", "z"};
  for (int e = 0; e < 2; ++e) {
    const std::string eye = std::string("head.") + models::kEyeNames[e] + ".";
    for (int a = 0; a < 3; ++a) add(eye + "centre_" + axes[a] + "_mm", head.geometry.centre_in_head[e](a) * 1000, "mm");
    const Eigen::Matrix3d r = head.geometry.cam_from_eye[e].rotation.toRotationMatrix();
    add(eye + "mount_roll_deg", std::atan2(r(1, 0), r(0, 0)) * kRadToDeg, "deg");
    add(eye + "mount_yaw_deg", std::asin(std::clamp(-r(2, 0), -1.0, 1.0)) * kRadToDeg, "deg");
    add(eye + "mount_pitch_deg", std::atan2(r(2, 1), r(2, 2)) * kRadToDeg, "deg");
    for (int a = 0; a < 3; ++a)
      add(eye + "mount_" + axes[a] + "_mm", head.geometry.cam_from_eye[e].translation(a) * 1000, "mm");
    if (with_intrinsics) {
      const char* names[] = {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"};
      for (size_t k = 0; k < head.intrinsics[e].params.size(); ++k)
        add(eye + names[k], head.intrinsics[e].params[k], k < 4 ? "px" : "");
    }
  }
  return out;
}

void SetHeadTruth(const models::HeadModel& truth, CalibrationResult* result) {
  for (const Parameter& t : HeadParameters(truth, true)) {
    for (Parameter& p : result->parameters) {
      if (p.name == t.name) p.truth = t.value;
    }
  }
}

std::array<double, 5> ShiftServoMapAngle(const std::array<double, 5>& params, int direction, double delta_rad) {
  const double n = ServoMap::kNormUs;
  const double s = params[1], q = params[2], c = params[3];
  const double target_deg = direction * delta_rad * kRadToDeg;
  // Solve deg(delta_us) = target with deg(x) = s x + q (x/N)^2 + c (x/N)^3.
  double x = target_deg / s;
  for (int it = 0; it < 60; ++it) {
    const double f = s * x + q * (x / n) * (x / n) + c * (x / n) * (x / n) * (x / n) - target_deg;
    const double df = s + 2 * q * x / (n * n) + 3 * c * x * x / (n * n * n);
    if (df == 0) break;
    const double step = f / df;
    x -= step;
    if (std::abs(step) < 1e-14) break;
  }
  std::array<double, 5> out = params;
  out[0] = params[0] + x;
  out[1] = s + 2 * q * x / (n * n) + 3 * c * x * x / (n * n * n);
  out[2] = q + 3 * c * x / n;
  out[3] = c;
  return out;
}

models::HeadModel CanonicalHead(const models::HeadModel& head,
                                double neck_centre_us,
                                bool neck_moved,
                                const Eigen::Vector3d& left_centre_fixed) {
  models::HeadModel h = head;
  // 1. Mount pitch (ZYX Euler: R = Rz(roll) Ry(yaw) Rx(pitch)) into the tilt map: t' = t - pitch.
  for (int e = 0; e < 2; ++e) {
    const Eigen::Matrix3d r = h.geometry.cam_from_eye[e].rotation.toRotationMatrix();
    const double pitch = std::atan2(r(2, 1), r(2, 2));
    h.geometry.cam_from_eye[e].rotation = h.geometry.cam_from_eye[e].rotation * models::RotX(-pitch);
    const int tilt = models::kTiltServo[e];
    h.servo_params[tilt] = ShiftServoMapAngle(h.servo_params[tilt], h.directions[tilt], pitch);
  }
  // 2. Head yaw a such that the centres have equal z in the new head frame: c' = RotY(-a) c,
  //    pan' = pan - a.
  const Eigen::Vector3d d = h.geometry.centre_in_head[kRightEye] - h.geometry.centre_in_head[kLeftEye];
  const double a = std::atan2(-d.z(), d.x());
  for (int e = 0; e < 2; ++e) {
    h.geometry.centre_in_head[e] = models::RotY(-a) * h.geometry.centre_in_head[e];
    const int pan = models::kPanServo[e];
    h.servo_params[pan] = ShiftServoMapAngle(h.servo_params[pan], h.directions[pan], a);
  }
  // 3. Neck zero at the configured centre (the base frame absorbs a constant neck angle).
  const double neck0 = h.ServoAngle(kNeck, neck_centre_us, 0);
  h.servo_params[kNeck] = ShiftServoMapAngle(h.servo_params[kNeck], h.directions[kNeck], neck0);
  // 4. Base origin.
  Eigen::Vector3d shift = left_centre_fixed - h.geometry.centre_in_head[kLeftEye];
  if (neck_moved) shift = Eigen::Vector3d(0, shift.y(), 0);
  for (int e = 0; e < 2; ++e) h.geometry.centre_in_head[e] += shift;
  return h;
}

}  // namespace owlcal::fitting
