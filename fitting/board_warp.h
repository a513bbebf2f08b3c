#pragma once
// The bow of a calibration board, fitted with the cameras (mrcal's two-parameter board
// deformation): a corner at (x, y, 0) on the flat board lies at
//   z = -(warp_x (1 - u^2) + warp_y (1 - v^2)),
// u and v running from -1 to 1 across the corner grid along target x and y (the span of the
// corners the views show; for a chessboard every view shows the whole grid). Positive values bow
// the middle towards the camera. Same model as the virtual Owl's (sim/scene.h SceneTarget::warp_m).
//
// Why: a course board bows by about 1 mm (measured on kit2020 and darvill2019, FACTS). Fitted as
// flat, a bow of 0.25-0.55 mm put both focal lengths 0.6-1.2 % short, every servo scale 1.2-1.6 %
// high and the IPD 1.5-2 mm short on robots of the prior (bench/robot_prior_mc_bench.cc), 20-30
// sigma: a systematic error no amount of views averages away. Modelled, not widened for.
//
// Usage (inside a residual):
//   const WarpSpan span = WarpSpanOfViews(views, "chessboard");
//   Eigen::Matrix<T, 3, 1> p = WarpedPoint(warp /* 2 params [m] */, point_in_target, span);
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/observation.h"

namespace owlcal::fitting {

struct WarpSpan {
  double centre_x = 0, centre_y = 0;
  double half_x = 1, half_y = 1;  // > 0
};

// The span of the corners of every view whose target_id is `board` or starts with `board@`
// (protocols::ReadViewsByPlacement names one placement "chessboard@placement2"); empty board:
// every view. Half widths are at least 1e-9.
WarpSpan WarpSpanOfViews(const std::vector<calib::View>& views, const std::string& board = "");

// The physical board of a target id: "chessboard@placement2" -> "chessboard".
std::string BoardOfTarget(const std::string& target_id);

// warp == nullptr: the flat board.
template <typename T>
Eigen::Matrix<T, 3, 1> WarpedPoint(const T* warp, const Eigen::Vector3d& p, const WarpSpan& s) {
  if (warp == nullptr) return p.cast<T>();
  const double u = (p.x() - s.centre_x) / s.half_x;
  const double v = (p.y() - s.centre_y) / s.half_y;
  return Eigen::Matrix<T, 3, 1>(T(p.x()), T(p.y()), T(p.z()) - (warp[0] * (1 - u * u) + warp[1] * (1 - v * v)));
}

}  // namespace owlcal::fitting
