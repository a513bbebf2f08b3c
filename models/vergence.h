#pragma once
// Vergence ranging: range to a fixated target from the two eyes' pan angles.
//
// Geometry (the guide's Fig. 16): eye rotation centres IPD apart on the x axis, the
// midpoint at the origin, z forward. Each eye's inward angle is measured from the parallel
// (straight-ahead) gaze and is positive when the eye turns towards the nose:
//   theta_left  =  pan_left   (left eye turns right to converge)
//   theta_right = -pan_right  (right eye turns left to converge)
// The target lies at depth Z and lateral offset x from the midpoint:
//   x + IPD/2 = Z tan(theta_left),  IPD/2 - x = Z tan(theta_right)
//
// Three forms, which agree on consistent inputs:
//   SymmetricDepth(ipd, theta)          Z = (IPD/2) / tan(theta)     (theta_l = theta_r)
//   SineRuleLeftDistance(ipd, tl, tr)   D_l = IPD cos(tr) / sin(tl + tr), the distance from the
//                                       left eye's centre (the guide's and students' formula);
//                                       depth Z = D_l cos(tl), x = D_l sin(tl) - IPD/2
//   ClosestPointOfRays(o1, d1, o2, d2)  the midpoint of the shortest segment between two
//                                       gaze rays in 3-D (handles tilt and any geometry).
#include <cmath>
#include <optional>

#include <Eigen/Core>

namespace owlcal::models {

inline double SymmetricDepth(double ipd, double theta_rad) { return 0.5 * ipd / std::tan(theta_rad); }

inline double SineRuleLeftDistance(double ipd, double theta_left_rad, double theta_right_rad) {
  return ipd * std::cos(theta_right_rad) / std::sin(theta_left_rad + theta_right_rad);
}

struct PlanarFix {
  double depth;    // Z from the baseline [m]
  double lateral;  // x from the midpoint [m]
  double range;    // distance from the midpoint [m]
};

// The target point in the plane from the sine rule.
inline PlanarFix SineRuleFix(double ipd, double theta_left_rad, double theta_right_rad) {
  const double dl = SineRuleLeftDistance(ipd, theta_left_rad, theta_right_rad);
  PlanarFix f;
  f.depth = dl * std::cos(theta_left_rad);
  f.lateral = dl * std::sin(theta_left_rad) - 0.5 * ipd;
  f.range = std::hypot(f.depth, f.lateral);
  return f;
}

// Closed form of the same point: Z = IPD / (tan tl + tan tr).
inline double TangentDepth(double ipd, double theta_left_rad, double theta_right_rad) {
  return ipd / (std::tan(theta_left_rad) + std::tan(theta_right_rad));
}

struct RayFix {
  Eigen::Vector3d point;  // midpoint of the shortest segment between the rays
  double gap;             // length of that segment (0 for intersecting rays) [m]
  double s1, s2;          // ray parameters of the closest points (> 0: in front)
};

// Closest point of two rays o + s d (d need not be unit). nullopt for parallel rays.
inline std::optional<RayFix> ClosestPointOfRays(const Eigen::Vector3d& o1,
                                                const Eigen::Vector3d& d1,
                                                const Eigen::Vector3d& o2,
                                                const Eigen::Vector3d& d2) {
  const Eigen::Vector3d w = o1 - o2;
  const double a = d1.dot(d1), b = d1.dot(d2), c = d2.dot(d2), d = d1.dot(w), e = d2.dot(w);
  const double den = a * c - b * b;
  if (std::abs(den) < 1e-15 * a * c) return std::nullopt;
  RayFix f;
  f.s1 = (b * e - c * d) / den;
  f.s2 = (a * e - b * d) / den;
  const Eigen::Vector3d p1 = o1 + f.s1 * d1, p2 = o2 + f.s2 * d2;
  f.point = 0.5 * (p1 + p2);
  f.gap = (p1 - p2).norm();
  return f;
}

}  // namespace owlcal::models
