#pragma once
// The head fit's parameter blocks, Ceres problem and phases (internal to fitting/: FitHead in
// fitting/head_fit.cc; see fitting/head_fit.h for what is estimated and fitting/head_gauge.h for
// what is held).
//
// Blocks (values in SI inside, `scale` converts to the result's unit):
//   servo[i]   models::ServoMap params of servo i (wire order)
//   mount[e]   fitting/head_residuals.h MountParams: roll, yaw [rad], x, y, z [m]
//   centres    head_residuals.h CentresParams: left x, y, z, right x, y [m] (right z = left z)
//   camera[e]  intrinsics of eye e (models/camera_model.h order)
//   boards     base_from_target of each target, 7-block [qx qy qz qw tx ty tz]
// An entry is held (SubsetManifold, or the whole block constant) when `fixed`, with the reason
// in `fixed_note`.
#include <array>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <ceres/problem.h>
#include <ceres/solver.h>
#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "calib/observation.h"
#include "fitting/head_fit.h"
#include "fitting/head_residuals.h"
#include "fitting/observability.h"
#include "models/rigid3.h"
#include "models/robot_config.h"

namespace owlcal::fitting::internal {

// One Ceres parameter block and how its entries are reported.
struct Block {
  std::vector<double> values;
  std::vector<std::string> names;  // report names per ambient entry (tangent names for poses)
  std::vector<double> scale;       // internal -> report unit
  std::vector<std::string> units;
  std::vector<bool> fixed;
  std::vector<std::string> fixed_note;
  bool is_pose = false;
  bool in_problem = false;

  double* data() { return values.data(); }
  const double* data() const { return values.data(); }
  int size() const { return static_cast<int>(values.size()); }
  bool AllFixed() const;
  // Free (tangent) entries: 6 for a pose, else the entries not fixed.
  int TangentSize() const;
  // Ambient index of tangent index k (Euclidean blocks), -1 when out of range.
  int AmbientOfTangent(int k) const;
  // Holds entry i with `note`; the first (most specific) reason is kept.
  void Fix(int i, const std::string& note);
  void FixAll(const std::string& note);
};

Block MakeBlock(const std::vector<double>& values,
                const std::vector<std::string>& names,
                const std::vector<double>& scale,
                const std::vector<std::string>& units);

// A view prepared for the residual: the data that survived filtering.
struct PreparedView {
  int index = 0;  // into the input views
  HeadViewCommand command;
  std::string target_id;
  int noise_class = 0;  // index into the fit's noise classes (HeadFitOptions::noise_class_of_board)
  std::vector<int> corner_ids;
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> pixels;  // what the residuals compare with: detected minus edge_offset
  std::vector<bool> inlier;
  // Tag corners (HeadFitOptions::tag_size_of_board): where the detector puts the corner minus
  // the corner's projection (fitting/tag_edge_corner.h) at the state CorrectTagEdgeCorners saw,
  // and the detected pixels; empty for other boards.
  std::vector<Eigen::Vector2d> edge_offset;
  std::vector<Eigen::Vector2d> detected;
};

struct HeadState {
  std::array<Block, models::kNumServos> servo;
  std::array<Block, 2> mount;
  Block centres;
  std::array<Block, 2> camera;
  std::map<std::string, Block> boards;
  // The bow of each physical board (fitting/board_warp.h; "chessboard" for the placements
  // "chessboard@placementN"): [warp_x, warp_y] in m, held at 0 unless options.fit_board_warp.
  std::map<std::string, Block> warps;
  std::map<std::string, WarpSpan> warp_spans;
  models::DistortionModel camera_model[2];
  // Mean of each eye's intrinsics prior (HeadFitOptions::intrinsics_prior_covariance): the
  // initial head's intrinsics, fixed when the state is made. Not the current estimate: the head
  // is solved up to three times (robust, final, re-whitened), and a prior rebuilt around the
  // previous solve's intrinsics would pull towards that solve, not towards the stereo fit's.
  std::array<std::vector<double>, 2> prior_mean;
  // Which input view (PreparedView::index) each view residual block of the last built problem
  // holds (BuildHeadProblem fills it): the clusters of the cluster-robust covariance.
  std::map<ceres::ResidualBlockId, int> input_view_of_residual;

  // The blocks in the order of the observability analysis and the covariance: servos, mounts,
  // centres, cameras, warps (`head_blocks`), then the boards.
  std::vector<Block*> HeadBlocks();
  std::vector<Block*> BoardBlocks();
};

HeadViewCommand CommandOf(const calib::View& v, const models::RobotConfig& robot);
models::Rigid3d CamFromBase(const HeadState& s, const HeadViewCommand& c);
// Per-corner reprojection error |projected - measured| [px] at the current state; NaN where the
// point does not project.
std::vector<double> CornerErrorsPx(const HeadState& s, const PreparedView& v);

// For the views of boards in options.tag_size_of_board: each corner's edge offset at the state
// `s` (the detector's straight-edge corner minus the corner's projection, fitting/tag_edge_corner.h),
// and pixels = detected - offset. A corner whose offset cannot be computed keeps offset 0.
// Returns the number of corners corrected.
int CorrectTagEdgeCorners(const HeadState& s, const HeadFitOptions& options, std::vector<PreparedView>* views);

// Adds one residual block per view over its inlier corners (every `stride`-th when
// max_corners_per_view > 0), the intrinsics priors, and the manifolds / constant blocks of
// what is held; sets Block::in_problem. Returns the number of corners used.
int BuildHeadProblem(HeadState* s,
                     const std::vector<PreparedView>& views,
                     const std::vector<std::array<double, 2>>& sigma_px,  // whitening per noise class, eye [px]
                     double huber_k,
                     const HeadFitOptions& options,
                     int max_corners_per_view,
                     ceres::Problem* problem);

ceres::Solver::Summary SolveHeadProblem(ceres::Problem* problem, const HeadFitOptions& options, double tolerance);

// Set-up phases of FitHead (fitting/head_fit_setup.cc).
// Views with a valid eye, matching pixels/points and enough corners; the malformed ones are named
// in `warnings`, those with too few corners in one line of `notes`.
std::vector<PreparedView> PrepareViews(const std::vector<calib::View>& views,
                                       const models::RobotConfig& robot,
                                       const HeadFitOptions& options,
                                       std::vector<std::string>* warnings,
                                       std::vector<std::string>* notes);
// Blocks from `initial`; neck centre from the robot file.
HeadState InitialState(const models::HeadModel& initial, const models::RobotConfig& robot);
// Holds, with the reason, what the data cannot determine before the solve (eyes without views,
// servos with too few distinct pulse widths or one approach, the gauge of fitting/head_gauge.h,
// options). Returns whether the neck moved.
bool HoldWhatTheDataCannotDetermine(const std::vector<calib::View>& views,
                                    const std::vector<PreparedView>& prepared,
                                    const models::RobotConfig& robot,
                                    const HeadFitOptions& options,
                                    HeadState* s);
// One base_from_target per target: PnP on its view with the most corners, chained through the
// initial head. Views of targets whose PnP fails are removed and named in `warnings`.
void InitialiseBoards(const std::vector<calib::View>& views,
                      std::vector<PreparedView>* prepared,
                      HeadState* s,
                      std::vector<std::string>* warnings);

// One warp block per physical board of `prepared` (fitting/board_warp.h), its span over `views`;
// held at 0 (whole block constant) unless options.fit_board_warp.
void InitialiseWarps(const std::vector<calib::View>& views,
                     const std::vector<PreparedView>& prepared,
                     const HeadFitOptions& options,
                     HeadState* s);

// The observability analysis of the free head blocks (boards eliminated).
struct HeadCovariance {
  Observability analysis;  // over the tangent coordinates below (ok = false: nothing free)
  std::map<std::pair<const Block*, int>, int> tangent_of;  // (block, ambient index) -> tangent index
  // HeadFitOptions::covariance_clusters: the clusters used, and the sigma of each coordinate
  // from the residuals over the model's (white noise at the measured sigma); empty when off.
  int num_clusters = 0;
  std::string clusters_message;
  std::vector<std::string> names;  // per tangent coordinate
  Eigen::VectorXd robust_sigma_ratio;
};

// Outputs of FitHead (fitting/head_fit_output.cc): the head model, every parameter with sigma
// or its reason, the IPD, the covariance of the determined parameters, the undetermined list,
// grouped warnings and the diagnostics.
void WriteHeadOutputs(const models::HeadModel& initial,
                      const models::RobotConfig& robot,
                      const HeadFitOptions& options,
                      const HeadState& s,
                      const HeadCovariance& cov,
                      size_t num_views_given,
                      HeadFit* fit);

// Stage timings for the diagnostics.
class StageTimer {
 public:
  StageTimer() : start_(std::chrono::steady_clock::now()), last_(start_) {}
  void Mark(const char* stage) {
    const auto now = std::chrono::steady_clock::now();
    timing_[stage] = std::chrono::duration<double>(now - last_).count();
    last_ = now;
  }
  double TotalS() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }
  const nlohmann::json& Timing() const { return timing_; }

 private:
  std::chrono::steady_clock::time_point start_, last_;
  nlohmann::json timing_ = nlohmann::json::object();
};

// The solve of FitHead (fitting/head_fit_solve.cc).
struct HeadSolveOutcome {
  ceres::Solver::Summary final_summary;
  int iterations = 0;
  double initial_cost = 0;
};
// The noise classes of the views (index 0: kDefaultNoiseClass, then the named classes in
// order); sets PreparedView::noise_class.
std::vector<std::string> AssignNoiseClasses(const HeadFitOptions& options, std::vector<PreparedView>* prepared);
// Stage 1: robust solve on a spread subset of corners; rejection of corners beyond
// outlier_threshold_sigma and of whole views the model does not explain; stage 2: plain solve on
// every inlier (its Jacobian is the one the observability analysis reads), whitened again with
// the measured noise when options.estimate_corner_sigma. Blocks no residual involves are marked
// not determined.
HeadSolveOutcome SolveWithOutlierRejection(const std::vector<calib::View>& views,
                                           const HeadFitOptions& options,
                                           const std::vector<std::string>& classes,
                                           std::vector<PreparedView>* prepared,
                                           HeadState* s,
                                           std::unique_ptr<ceres::Problem>* problem,
                                           HeadFit* fit,
                                           StageTimer* timer);

// The covariance of FitHead (fitting/head_fit_covariance.cc).
// The observability analysis over the free head blocks with the boards eliminated, cluster-robust
// when options.covariance_clusters is set.
HeadCovariance AnalyseHead(ceres::Problem* problem,
                           HeadState* s,
                           const std::vector<calib::View>& views,
                           const HeadFitOptions& options);
// What the floors of FloorHeadCovariance report: the pan zero's sigma after its widening [rad]
// and the focal scale's sigma before its floor; NaN when not applied.
struct HeadCovarianceFloors {
  double pan_zero_sigma_rad = NAN;
  double focal_scale_sigma = NAN;
};
// The floors and widenings of the options, in order: hysteresis, intrinsics (carried as
// intrinsics_floor_carry says), pan zero, focal scale, principal points. Nothing when the
// analysis failed.
HeadCovarianceFloors FloorHeadCovariance(const HeadState& s,
                                         const models::RobotConfig& robot,
                                         const HeadFitOptions& options,
                                         HeadCovariance* cov);

}  // namespace owlcal::fitting::internal
