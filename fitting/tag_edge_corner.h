#pragma once
// Where the AprilTag detector puts a tag's corner when the lens bends the tag's edges.
//
// calib/apriltag_free.h refines each corner as the intersection of two STRAIGHT lines, each
// fitted to the image of the middle 80 % of one of the corner's two edges. Under lens distortion
// an edge's image is curved (barrel distortion bows it away from the image centre), so the
// lines, and their intersection, are not the corner's own projection. On the virtual Owl's
// default lens the detected tag corners lie 0.014-0.016 px farther from the principal point than
// their projections at 100-400 px from it (tests/protocols/head_sim_consistency_test.cc), the
// same from both eyes and every sweep: a bias that pulled the head fit fusing the tag sheets
// by +0.06 % in the focal lengths and -0.04 % in the servo scales (4-6 sigma). A chessboard's
// saddle points are points, not line intersections, and have no such offset.
//
// TagEdgeCornerPixel models the detector: it projects 17 points along the middle 80 % of each
// edge with `project`, fits each edge's total-least-squares line and intersects them. The head
// fit compares a tag corner's detected pixel with that (HeadFitOptions::tag_size_of_board).
//
// Tag corners in the target frame (calib/target.h AprilGrid): corner k of a tag, k = 0
// top-left, 1 top-right, 2 bottom-right, 3 bottom-left (corner id = 4 * tag id + k), the tag's
// black border `tag_size_m` wide along target x and y.
//
// Usage:
//   const auto c = TagCornersOf(point_in_target, corner_id, 0.045);
//   auto project = [&](const Eigen::Vector3d& x, Eigen::Vector2d* px) { ... };
//   if (auto px = TagEdgeCornerPixel(project, c, corner_id % 4)) offset = *px - projected_corner;
#include <array>
#include <functional>
#include <optional>

#include <Eigen/Core>

namespace owlcal::fitting {

// The four corners (order above) of the tag that has corner `corner_id` at `corner_in_target`.
std::array<Eigen::Vector3d, 4> TagCornersOf(const Eigen::Vector3d& corner_in_target, int corner_id, double tag_size_m);

// The detector's corner k (0..3) of the tag with `corners_in_target`, through `project`
// (target point -> pixel, false when it cannot be projected). nullopt when a sample cannot be
// projected or the two edge lines are parallel in the image.
std::optional<Eigen::Vector2d> TagEdgeCornerPixel(
    const std::function<bool(const Eigen::Vector3d&, Eigen::Vector2d*)>& project,
    const std::array<Eigen::Vector3d, 4>& corners_in_target,
    int k);

}  // namespace owlcal::fitting
