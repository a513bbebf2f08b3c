// The set-up phases of FitHead (declared in fitting/head_problem.h): views, initial blocks,
// what is held, initial board poses.
#include "fitting/head_problem.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "fitting/head_gauge.h"
#include "models/units.h"

namespace owlcal::fitting::internal {
namespace {

using models::kLeftEye;
using models::kNeck;
using models::kNumServos;
using models::kRightEye;

}  // namespace

std::vector<PreparedView> PrepareViews(const std::vector<calib::View>& views,
                                       const models::RobotConfig& robot,
                                       const HeadFitOptions& options,
                                       std::vector<std::string>* warnings,
                                       std::vector<std::string>* notes) {
  std::vector<PreparedView> prepared;
  // Views with too few corners: one note for all of them (a tag sheet's edge views are many and
  // alike, and nothing is to be done), counted per target, each view named in it.
  std::map<std::string, std::vector<std::string>> too_few;
  for (size_t i = 0; i < views.size(); ++i) {
    const calib::View& v = views[i];
    const std::string where = "view " + std::to_string(i) + " (frame " + std::to_string(v.frame_index) + ")";
    if (v.eye != kLeftEye && v.eye != kRightEye) {
      warnings->push_back(where + ": eye = " + std::to_string(v.eye) + " is not 0 or 1; dropped");
      continue;
    }
    if (v.pixels.size() != v.points_in_target.size()) {
      warnings->push_back(where + ": " + std::to_string(v.pixels.size()) + " pixels but " +
                          std::to_string(v.points_in_target.size()) + " target points; dropped");
      continue;
    }
    if (static_cast<int>(v.pixels.size()) < options.min_corners_per_view) {
      too_few[v.target_id].push_back(where + ", " + std::to_string(v.pixels.size()) + " corners");
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
  if (!too_few.empty()) {
    size_t n = 0;
    std::string per_target, named;
    for (const auto& [target, list] : too_few) {
      n += list.size();
      per_target += (per_target.empty() ? "" : ", ") + target + " " + std::to_string(list.size());
      for (const std::string& v : list) named += (named.empty() ? "" : "; ") + v;
    }
    notes->push_back(std::to_string(n) + " view" + (n == 1 ? "" : "s") + " with fewer than " +
                     std::to_string(options.min_corners_per_view) + " corners dropped (" + per_target + "): " + named);
  }
  return prepared;
}

HeadState InitialState(const models::HeadModel& initial, const models::RobotConfig& robot) {
  HeadState s;
  for (int i = 0; i < kNumServos; ++i) {
    std::vector<double> p(initial.servo_params[i].begin(), initial.servo_params[i].end());
    if (i == kNeck) p[0] = robot.servos[kNeck].centre_us;
    std::vector<std::string> names;
    for (const char* n : kServoParamNames) names.push_back(std::string("servo.") + models::kServoNames[i] + "." + n);
    s.servo[i] = MakeBlock(p, names, {1, 1, 1, 1, 1}, std::vector<std::string>(kServoParamUnits, kServoParamUnits + 5));
  }
  for (int e = 0; e < 2; ++e) {
    const std::string eye = models::kEyeNames[e];
    const Eigen::Matrix3d r = initial.geometry.cam_from_eye[e].rotation.toRotationMatrix();
    const Eigen::Vector3d t = initial.geometry.cam_from_eye[e].translation;
    const double yaw = std::asin(std::clamp(-r(2, 0), -1.0, 1.0));
    const double roll = std::atan2(r(1, 0), r(0, 0));
    s.mount[e] = MakeBlock({roll, yaw, t.x(), t.y(), t.z()},
                           {"head." + eye + ".mount_roll_deg",
                            "head." + eye + ".mount_yaw_deg",
                            "head." + eye + ".mount_x_mm",
                            "head." + eye + ".mount_y_mm",
                            "head." + eye + ".mount_z_mm"},
                           {kRadToDeg, kRadToDeg, 1000, 1000, 1000},
                           {"deg", "deg", "mm", "mm", "mm"});
    s.camera_model[e] = initial.intrinsics[e].model;
    s.prior_mean[e] = initial.intrinsics[e].params;
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
                        {"head.left.centre_x_mm",
                         "head.left.centre_y_mm",
                         "head.left.centre_z_mm",
                         "head.right.centre_x_mm",
                         "head.right.centre_y_mm"},
                        {1000, 1000, 1000, 1000, 1000},
                        {"mm", "mm", "mm", "mm", "mm"});
  return s;
}

bool HoldWhatTheDataCannotDetermine(const std::vector<calib::View>& views,
                                    const std::vector<PreparedView>& prepared,
                                    const models::RobotConfig& robot,
                                    const HeadFitOptions& options,
                                    HeadState* state) {
  HeadState& s = *state;
  int views_per_eye[2] = {0, 0};
  std::array<std::set<int>, kNumServos> pwm_seen;
  std::array<std::set<int>, kNumServos> approach_seen;
  for (const PreparedView& p : prepared) {
    const calib::View& v = views[p.index];
    views_per_eye[v.eye]++;
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
    s.servo[kNeck].FixAll(
        "not determined: the neck never moved (" +
        (pwm_seen[kNeck].empty() ? std::string("no view") : std::to_string(*pwm_seen[kNeck].begin()) + " us") +
        " in every view)");
  }
  s.servo[kNeck].Fix(0,
                     "fixed at the robot file's centre " + std::to_string(robot.servos[kNeck].centre_us) +
                         " us: the neck's zero only turns the base frame, which no board observation sees (gauge)");
  for (int i = 0; i < kNumServos; ++i) {
    Block& b = s.servo[i];
    const std::string name = models::kServoNames[i];
    const size_t distinct = pwm_seen[i].size();
    if (distinct == 1) {
      b.FixAll("not determined: " + name + " took one pulse width only (" + std::to_string(*pwm_seen[i].begin()) +
               " us)");
    } else if (distinct == 2) {
      b.Fix(2, "not determined: " + name + " took only 2 distinct pulse widths");
      b.Fix(3, "not determined: " + name + " took only 2 distinct pulse widths");
    } else if (distinct == 3) {
      b.Fix(3, "not determined: " + name + " took only 3 distinct pulse widths");
    }
    if (approach_seen[i].size() < 2)
      b.Fix(4,
            "not determined: " + name + " was never approached from both directions (held at " +
                std::to_string(b.values[4]) + " us)");
    if (!options.fit_nonlinear) {
      b.Fix(2, "held at " + std::to_string(b.values[2]) + " by option fit_nonlinear = false");
      b.Fix(3, "held at " + std::to_string(b.values[3]) + " by option fit_nonlinear = false");
    }
    if (!options.fit_hysteresis)
      b.Fix(4, "held at " + std::to_string(b.values[4]) + " us by option fit_hysteresis = false");
  }
  if (neck_moved) {
    s.centres.Fix(1,
                  "fixed at " + std::to_string(s.centres.values[1] * 1000) +
                      " mm: the base frame's height along the neck axis is a gauge (boards move with it)");
  } else {
    for (int k = 0; k < 3; ++k)
      s.centres.Fix(k,
                    "fixed at the initial value: without neck motion the base origin is a gauge (boards move with it)");
  }
  if (!options.fit_intrinsics) {
    for (int e = 0; e < 2; ++e) s.camera[e].FixAll("held at the given intrinsics (fit_intrinsics = false)");
  }
  // The rational model's inseparable radial terms (HeadFitOptions::rational_fix_radial); the
  // parameter order is fx fy cx cy k1 k2 p1 p2 k3 k4 k5 k6.
  constexpr int kRadialIndex[7] = {-1, 4, 5, 8, 9, 10, 11};
  for (int e = 0; e < 2; ++e)
    if (s.camera_model[e] == models::DistortionModel::kOpenCv8)
      for (int k : options.rational_fix_radial)
        if (k >= 1 && k <= 6)
          s.camera[e].Fix(kRadialIndex[k],
                          "held: the rational model's k" + std::to_string(k) +
                              " trades against its other radial terms (rational_fix_radial)");
  return neck_moved;
}

void InitialiseBoards(const std::vector<calib::View>& views,
                      std::vector<PreparedView>* prepared_views,
                      HeadState* state,
                      std::vector<std::string>* warnings) {
  HeadState& s = *state;
  std::vector<PreparedView>& prepared = *prepared_views;
  std::set<std::string> targets;
  for (const PreparedView& p : prepared) targets.insert(p.target_id);
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
      warnings->push_back("target '" + id + "': PnP failed on frame " + std::to_string(views[best->index].frame_index) +
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
  prepared.erase(
      std::remove_if(
          prepared.begin(), prepared.end(), [&](const PreparedView& p) { return !s.boards.count(p.target_id); }),
      prepared.end());
}

void InitialiseWarps(const std::vector<calib::View>& views,
                     const std::vector<PreparedView>& prepared,
                     const HeadFitOptions& options,
                     HeadState* s) {
  for (const PreparedView& p : prepared) {
    const std::string board = BoardOfTarget(p.target_id);
    if (s->warps.count(board)) continue;
    s->warp_spans[board] = WarpSpanOfViews(views, board);
    Block b = MakeBlock({0.0, 0.0}, {"head.board_warp_x_mm", "head.board_warp_y_mm"}, {1000.0, 1000.0}, {"mm", "mm"});
    if (board != "chessboard")
      for (std::string& n : b.names) n = "head." + board + n.substr(4);  // "head.<board>.board_warp_x_mm"
    if (!options.fit_board_warp) b.FixAll("held flat (option fit_board_warp = false)");
    s->warps.emplace(board, std::move(b));
  }
}

}  // namespace owlcal::fitting::internal
