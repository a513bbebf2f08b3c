#pragma once
// The one joint angle that puts a known point on a given image column: what the tracking
// protocols (VOR, main sequence) ask to turn a located target into the angle the eye or the neck
// is at.
#include <algorithm>
#include <cmath>
#include <optional>

#include <Eigen/Core>

#include "models/head_model.h"

namespace owlcal::models {

// Which joint SolveJointForColumn moves: the neck, or the eye's pan.
enum class ColumnJoint { kNeck, kPan };

// The angle [rad] of `joint` that projects x_in_base to pixel column x_px in `eye`, with the other
// joints at `a`: Newton on the column (a 1e-6 rad forward difference, steps clamped to 0.2 rad,
// 20 iterations, |column error| < 1e-6 px); nullopt when it does not converge or the point leaves
// the image model.
inline std::optional<double> SolveJointForColumn(
    const HeadModel& head, Eye eye, JointAngles a, const Eigen::Vector3d& x_in_base, double x_px, ColumnJoint joint) {
  double& q = joint == ColumnJoint::kNeck ? a.neck_rad : a.pan_rad[eye];
  for (int it = 0; it < 20; ++it) {
    Eigen::Vector2d p0, p1;
    if (!head.Project(eye, a, x_in_base, &p0)) return std::nullopt;
    const double r = p0.x() - x_px;
    if (std::abs(r) < 1e-6) return q;
    q += 1e-6;
    const bool ok = head.Project(eye, a, x_in_base, &p1);
    q -= 1e-6;
    if (!ok) return std::nullopt;
    const double d = (p1.x() - p0.x()) / 1e-6;
    if (std::abs(d) < 1e-9) return std::nullopt;
    q -= std::clamp(r / d, -0.2, 0.2);
  }
  return std::nullopt;
}

}  // namespace owlcal::models
