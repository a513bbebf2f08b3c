#include "fitting/head_problem.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <ceres/ceres.h>
#include <ceres/manifold.h>
#include <ceres/product_manifold.h>

#include "fitting/tag_edge_corner.h"
#include "models/head_kinematics.h"
#include "models/servo_map.h"
#include "models/units.h"

namespace owlcal::fitting::internal {
namespace {

using models::kNeck;
using models::ServoMap;

}  // namespace

bool Block::AllFixed() const {
  return std::all_of(fixed.begin(), fixed.end(), [](bool f) { return f; });
}

int Block::TangentSize() const {
  if (is_pose) return 6;
  return static_cast<int>(std::count(fixed.begin(), fixed.end(), false));
}

int Block::AmbientOfTangent(int k) const {
  int seen = 0;
  for (int i = 0; i < size(); ++i) {
    if (!fixed[i] && seen++ == k) return i;
  }
  return -1;
}

void Block::Fix(int i, const std::string& note) {
  if (fixed[i]) return;
  fixed[i] = true;
  fixed_note[i] = note;
}

void Block::FixAll(const std::string& note) {
  for (int i = 0; i < size(); ++i) Fix(i, note);
}

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

std::vector<Block*> HeadState::HeadBlocks() {
  std::vector<Block*> out;
  for (Block& b : servo) out.push_back(&b);
  for (Block& b : mount) out.push_back(&b);
  out.push_back(&centres);
  for (Block& b : camera) out.push_back(&b);
  for (auto& [id, b] : warps) out.push_back(&b);
  return out;
}

std::vector<Block*> HeadState::BoardBlocks() {
  std::vector<Block*> out;
  for (auto& [id, b] : boards) out.push_back(&b);
  return out;
}

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

models::Rigid3d CamFromBase(const HeadState& s, const HeadViewCommand& c) {
  const int eye = c.eye;
  const double pan =
      ServoMap::JointAngle(s.servo[models::kPanServo[eye]].data(), c.pan_direction, c.pan_us, c.pan_approach);
  const double tilt =
      ServoMap::JointAngle(s.servo[models::kTiltServo[eye]].data(), c.tilt_direction, c.tilt_us, c.tilt_approach);
  const double neck = ServoMap::JointAngle(s.servo[kNeck].data(), c.neck_direction, c.neck_us, c.neck_approach);
  double centre[3];
  EyeCentreOfCentres(s.centres.data(), eye, centre);
  return CamFromEyeOfMount(s.mount[eye].data()) * models::HeadFromEye(centre, pan, tilt).Inverse() *
         models::HeadFromBase(neck);
}

std::vector<double> CornerErrorsPx(const HeadState& s, const PreparedView& v) {
  const models::Rigid3d cam_from_target =
      CamFromBase(s, v.command) * models::Rigid3d::Map(s.boards.at(v.target_id).data());
  std::vector<double> err(v.pixels.size(), kNaN);
  models::CameraIntrinsics cam;
  cam.model = s.camera_model[v.command.eye];
  cam.params = s.camera[v.command.eye].values;
  const std::string board = BoardOfTarget(v.target_id);
  const double* warp = s.warps.at(board).data();
  const WarpSpan& span = s.warp_spans.at(board);
  for (size_t i = 0; i < v.pixels.size(); ++i) {
    const Eigen::Vector3d p = cam_from_target * WarpedPoint(warp, v.points[i], span);
    Eigen::Vector2d px;
    if (cam.Project(p.data(), px.data())) err[i] = (px - v.pixels[i]).norm();
  }
  return err;
}

int CorrectTagEdgeCorners(const HeadState& s, const HeadFitOptions& options, std::vector<PreparedView>* views) {
  int num = 0;
  for (PreparedView& v : *views) {
    const std::string board = BoardOfTarget(v.target_id);
    const auto size = options.tag_size_of_board.find(board);
    if (size == options.tag_size_of_board.end()) continue;
    if (v.detected.empty()) v.detected = v.pixels;
    v.edge_offset.assign(v.pixels.size(), Eigen::Vector2d::Zero());
    const models::Rigid3d cam_from_target =
        CamFromBase(s, v.command) * models::Rigid3d::Map(s.boards.at(v.target_id).data());
    models::CameraIntrinsics cam;
    cam.model = s.camera_model[v.command.eye];
    cam.params = s.camera[v.command.eye].values;
    const double* warp = s.warps.at(board).data();
    const WarpSpan& span = s.warp_spans.at(board);
    auto project = [&](const Eigen::Vector3d& x, Eigen::Vector2d* px) {
      const Eigen::Vector3d p = cam_from_target * WarpedPoint(warp, x, span);
      return cam.Project(p.data(), px->data());
    };
    for (size_t i = 0; i < v.pixels.size(); ++i) {
      Eigen::Vector2d at;
      if (v.corner_ids[i] >= 0 && project(v.points[i], &at)) {
        const auto edge =
            TagEdgeCornerPixel(project, TagCornersOf(v.points[i], v.corner_ids[i], size->second), v.corner_ids[i] % 4);
        if (edge) {
          v.edge_offset[i] = *edge - at;
          ++num;
        }
      }
      v.pixels[i] = v.detected[i] - v.edge_offset[i];
    }
  }
  return num;
}

int BuildHeadProblem(HeadState* state,
                     const std::vector<PreparedView>& views,
                     const std::vector<std::array<double, 2>>& sigma_px,
                     double huber_k,
                     const HeadFitOptions& options,
                     int max_corners_per_view,
                     ceres::Problem* problem) {
  HeadState& s = *state;
  s.input_view_of_residual.clear();
  int num_corners = 0;
  for (const PreparedView& v : views) {
    const int eye = v.command.eye;
    const int stride =
        max_corners_per_view > 0 ? std::max<int>(1, static_cast<int>(v.pixels.size()) / max_corners_per_view) : 1;
    Block& board = s.boards.at(v.target_id);
    const std::string board_name = BoardOfTarget(v.target_id);
    Block& warp = s.warps.at(board_name);
    double* blocks[8] = {s.servo[models::kPanServo[eye]].data(),
                         s.servo[models::kTiltServo[eye]].data(),
                         s.servo[kNeck].data(),
                         s.mount[eye].data(),
                         s.centres.data(),
                         board.data(),
                         s.camera[eye].data(),
                         warp.data()};
    ceres::CostFunction* cost =
        models::VisitCameraModel(s.camera_model[eye], [&]<typename Camera>() -> ceres::CostFunction* {
          auto* f = new HeadViewResidual<Camera>;
          f->command = v.command;
          f->sigma_px = sigma_px.at(v.noise_class)[eye];
          f->huber_k = huber_k;
          f->span = s.warp_spans.at(board_name);
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
          return new ceres::AutoDiffCostFunction<HeadViewResidual<Camera>,
                                                 ceres::DYNAMIC,
                                                 ServoMap::kNumParams,
                                                 ServoMap::kNumParams,
                                                 ServoMap::kNumParams,
                                                 kMountParams,
                                                 kCentresParams,
                                                 7,
                                                 Camera::kNumParams,
                                                 2>(f, f->NumResiduals());
        });
    if (cost == nullptr) continue;
    s.input_view_of_residual[problem->AddResidualBlock(
        cost, nullptr, blocks[0], blocks[1], blocks[2], blocks[3], blocks[4], blocks[5], blocks[6], blocks[7])] =
        v.index;
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
      f->mean = Eigen::Map<const Eigen::Matrix<double, N, 1>>(s.prior_mean[e].data());
      f->sqrt_information = upper;
      problem->AddResidualBlock(
          new ceres::AutoDiffCostFunction<GaussianPriorResidual<N>, N, N>(f), nullptr, s.camera[e].data());
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
  for (auto& [id, b] : s.warps) configure(b);
  for (auto& [id, b] : s.boards) configure(b);
  return num_corners;
}

ceres::Solver::Summary SolveHeadProblem(ceres::Problem* problem, const HeadFitOptions& options, double tolerance) {
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

}  // namespace owlcal::fitting::internal
