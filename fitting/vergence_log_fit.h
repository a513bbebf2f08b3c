#pragma once
// Eye-pan maps from a vergence log: rows of (true distance, Rx, Lx) recorded while both eyes
// fixate one target (data/owl-real/noble2020-vergence-range).
//
// Model (head frame of models/vergence.h: eye rotation centres IPD apart on x, midpoint at
// the origin, z forward). Run r's target moves along a line from the midpoint at bearing
// phi_r (positive to the robot's right); the logged distance D is measured from a datum
// plane d0 in front of the eye centres, so the target sits at range rho = D + d0:
//   x = rho sin(phi_r),  z = rho cos(phi_r)
//   theta_L = atan2(x + IPD/2, z),  theta_R = atan2(IPD/2 - x, z)   (inward, rad)
//   Lx = lx_centre + lx_us_per_deg * deg(theta_L)
//   Rx = rx_centre - rx_us_per_deg * deg(theta_R)
// (Converging means Rx down and Lx up, docs/conventions.md, Facts.) Residuals are in PWM space, whitened by
// `pwm_sigma_us`; the reported sigmas are scaled by the fit's own residual spread
// (sqrt(chi2/dof)) when that is larger than 1, i.e. the data's scatter, not the prior.
//
// What the data determine: a vergence log fixes each eye's centre and (IPD x scale), and
// the datum through the 1/(D + d0) curvature. IPD and the scales separate only through the
// atan non-linearity at the nearest rows; IpdMode::kAuto frees IPD only when its sigma is
// below `ipd_sigma_threshold_m`, else fixes it and says so. phi of the first run is fixed at
// 0 (a common bearing is indistinguishable from both centres moving), so centres are
// "parallel gaze along run 1's target line".
//
// Prediction inverts the model with the sine rule (models/vergence.h) and needs no bearing:
// distance from the datum = |fix point - midpoint| - d0.
#include <optional>
#include <string>
#include <vector>

#include "fitting/result.h"
#include "fitting/vergence_log_columns.h"
#include "models/robot_config.h"

namespace owlcal::fitting {

struct VergenceLogRow {
  int run = 1;
  double true_distance_m = 0;  // as logged, from the (unknown) datum
  double rx_us = 0;            // right eye pan PWM
  double lx_us = 0;            // left eye pan PWM
};

// Reads a CSV (calib/csv.h) with a header naming the columns (fitting/vergence_log_columns.h:
// the true distance column must be the only distance-like one or be named in `columns`; Rx, Lx,
// run). Extra columns are ignored and listed in *used. Distances must be positive (up to 1 km),
// PWMs within 0..9999, all numbers finite. Throws naming the path, line and column.
std::vector<VergenceLogRow> ReadVergenceLogCsv(const std::string& path,
                                               const VergenceColumnRequest& columns = {},
                                               VergenceColumns* used = nullptr);

// The course's fixed-constant method (noble2020 README), per eye:
// theta_R = -dir_R (Rx - RxC)/k_R deg, theta_L = dir_L (Lx - LxC)/k_L deg (inward positive),
// lDist = IPD cos(theta_R)/sin(theta_L + theta_R),
// range = sqrt(lDist^2 + (IPD/2)^2 - lDist IPD sin(theta_L)) - offset.
// The defaults are noble2020's sheet (ITS robot: RxC 1445, LxC 1430, 10.73 us/deg); for another
// robot use FromRobot with that robot's file.
struct FixedConstantVergence {
  double rx_centre_us = 1445;
  double lx_centre_us = 1430;
  double rx_us_per_deg = 10.73;
  double lx_us_per_deg = 10.73;
  int rx_direction = 1, lx_direction = 1;  // +1: increasing PWM turns the eye to the robot's right
  double ipd_m = 0.065;
  double datum_offset_m = 0.030;
  std::string source = "noble2020 sheet constants";
  // From a robot file's Rx / Lx centres, deg_per_us and directions and its IPD.
  static FixedConstantVergence FromRobot(const models::RobotConfig& robot,
                                         double datum_offset_m,
                                         const std::string& source);
  // Distance from the datum [m]; nullopt when the rays do not converge.
  std::optional<double> Distance(double rx_us, double lx_us) const;
};

struct VergenceMaps {
  double rx_centre_us = 1445, rx_us_per_deg = 10.73;
  double lx_centre_us = 1430, lx_us_per_deg = 10.73;
  double ipd_m = 0.065;
  double datum_offset_m = 0.030;        // d0: eye-centre baseline to the distance datum [m]
  std::vector<double> run_bearing_rad;  // phi per run, in the order of VergenceLogFit::runs
  // Inward eye angles for a PWM pair [rad].
  double ThetaLeft(double lx_us) const;
  double ThetaRight(double rx_us) const;
  // Distance from the datum [m] by the sine rule; nullopt when the rays do not converge.
  std::optional<double> Distance(double rx_us, double lx_us) const;
  // Predicted PWM for a target at logged distance D on run index `run_index`'s line.
  void PredictPwm(double distance_m, int run_index, double* rx_us, double* lx_us) const;
};

enum class IpdMode { kFixed, kFree, kAuto };

struct VergenceFitOptions {
  double pwm_sigma_us = 1.0;  // prior per-reading sigma (quantisation 1 us + fixation)
  IpdMode ipd_mode = IpdMode::kAuto;
  double ipd_m = 0.065;  // value when fixed, start when free
  double ipd_sigma_threshold_m = 0.003;
  bool fit_datum = true;  // else datum fixed at datum_offset_m
  double datum_offset_m = 0.030;
  double datum_sigma_threshold_m = 0.05;  // above this the datum is fixed with a note
  bool per_run_bearing = true;            // one bearing per run after the first
  int max_iterations = 200;               // solver iterations; a fit that needs more is NO_CONVERGENCE, not usable
  VergenceMaps initial;                   // starting centres and scales
  bool Check(std::string* why) const;
};

struct VergenceRowDiagnostic {
  int row = 0;                              // index into the input rows
  double residual_rx = 0, residual_lx = 0;  // whitened (pred - obs) / pwm_sigma_us
  double chi2 = 0;                          // residual_rx^2 + residual_lx^2
  double range_per_us_m = 0;                // |d distance / d PWM| for 1 us on either eye (RSS) [m/us]
};

// summary.usable is true only when the solver converged and the covariance has full rank; then
// every parameter marked determined has a finite sigma. A failed solve reports no sigma and the
// Markdown report prints no value; data that cannot determine a parameter (one distance only,
// identical rows) leave it "not determined" with a note saying why.
struct VergenceLogFit {
  VergenceMaps maps;
  std::vector<int> runs;              // run ids, order of maps.run_bearing_rad
  std::vector<Parameter> parameters;  // rx.centre_us, rx.us_per_deg, lx.*, ipd_mm, datum_mm, bearing
  SolveSummary summary;
  double residual_sigma_us = 0;  // sqrt(chi2/dof) * pwm_sigma_us
  std::vector<VergenceRowDiagnostic> rows;
  std::vector<std::string> notes;  // what was fixed and why
  bool ipd_free = false;
  bool datum_free = false;
};

// Most runs a log may have: each adds a bearing parameter, and the dense solve and covariance grow
// with their square (a run column with a new id on every row would make the fit quadratic).
inline constexpr size_t kMaxVergenceRuns = 50;

// Fits the maps; throws std::invalid_argument when options fail Check, rows are too few, the log
// has more than kMaxVergenceRuns runs, or a row has a non-positive or non-finite distance or a
// non-finite PWM.
VergenceLogFit FitVergenceLog(const std::vector<VergenceLogRow>& rows, const VergenceFitOptions& options);

// Leave-one-out comparison on the same rows.
struct LooRow {
  int row = 0;
  double true_m = 0;
  std::optional<double> fixed_m;  // course fixed-constant estimate
  std::optional<double> loo_m;    // fitted on the other rows
};
// Most refits a leave-one-out comparison makes: a longer log is dealt round-robin into this many
// folds (row i in fold i % folds), each row predicted by a fit without its fold, so the cost
// stays linear in the rows (one refit per row would be quadratic).
inline constexpr size_t kMaxVergenceFolds = 100;
struct LooSummary {
  std::vector<LooRow> rows;
  int folds = 0;             // refits made: the rows, or kMaxVergenceFolds for a longer log
  bool has_fixed = false;    // a fixed-constant comparison was made
  std::string fixed_source;  // whose constants
  // Mean / median absolute relative error; rows without a fix count as 100 %.
  double fixed_mean_abs_rel = 0, fixed_median_abs_rel = 0;
  double loo_mean_abs_rel = 0, loo_median_abs_rel = 0;
  int fixed_failures = 0, loo_failures = 0;
};
// Each row is predicted by a fit on all other rows (on the other folds for a log longer than
// kMaxVergenceFolds rows), using the IPD / datum modes the full fit chose (`full`), so each fold
// solves the same problem.
LooSummary LeaveOneOut(const std::vector<VergenceLogRow>& rows,
                       const VergenceFitOptions& options,
                       const VergenceLogFit& full,
                       const FixedConstantVergence& fixed);
// Without a fixed-constant comparison (no constants of THIS robot given).
LooSummary LeaveOneOut(const std::vector<VergenceLogRow>& rows,
                       const VergenceFitOptions& options,
                       const VergenceLogFit& full);

}  // namespace owlcal::fitting
