// fitting/tag_edge_corner.h: where the detector's straight-edge corner lies for a tag seen
// through a lens. Without distortion it is the corner's projection; with the barrel distortion
// of an Owl lens it lies away from the principal point, by hundredths of a pixel.
#include <cmath>

#include <gtest/gtest.h>

#include "fitting/tag_edge_corner.h"
#include "models/camera_model.h"

namespace owlcal::fitting {
namespace {

TEST(TagEdgeCorner, TagCornersOfAnyCornerGiveTheSameTag) {
  const Eigen::Vector3d top_left(0.1, 0.2, 0);
  for (int k = 0; k < 4; ++k) {
    const auto c0 = TagCornersOf(top_left, 400, 0.045);
    const auto ck = TagCornersOf(c0[k], 400 + k, 0.045);
    for (int i = 0; i < 4; ++i) EXPECT_LT((ck[i] - c0[i]).norm(), 1e-12) << k << " " << i;
  }
  const auto c = TagCornersOf(top_left, 4 * 7 + 2, 0.045);  // the bottom-right corner of tag 7
  EXPECT_LT((c[2] - top_left).norm(), 1e-12);
  EXPECT_LT((c[0] - (top_left - Eigen::Vector3d(0.045, 0.045, 0))).norm(), 1e-12);
}

// A 45 mm tag 0.65 m away, facing the camera, at `offset` in the image plane.
struct Scene {
  models::CameraIntrinsics cam;
  Eigen::Vector3d tag_top_left_in_cam;
  bool Project(const Eigen::Vector3d& x, Eigen::Vector2d* px) const {
    const Eigen::Vector3d p = tag_top_left_in_cam + x;
    return cam.Project(p.data(), px->data());
  }
};

TEST(TagEdgeCorner, IsTheProjectionWithoutDistortionAndMovesOutwardWithBarrelDistortion) {
  Scene s;
  s.cam.width = 640;
  s.cam.height = 480;
  s.cam.params = {583.2, 582.4, 322.8, 236.1, 0, 0, 0, 0, 0};
  const std::array<Eigen::Vector3d, 4> tag = TagCornersOf(Eigen::Vector3d::Zero(), 0, 0.045);
  auto project = [&](const Eigen::Vector3d& x, Eigen::Vector2d* px) { return s.Project(x, px); };
  for (const Eigen::Vector3d& at : {Eigen::Vector3d(0.15, 0.1, 0.65), Eigen::Vector3d(-0.25, -0.2, 0.65)}) {
    s.tag_top_left_in_cam = at;
    s.cam.params[4] = s.cam.params[5] = s.cam.params[8] = 0;
    for (int k = 0; k < 4; ++k) {
      Eigen::Vector2d px;
      ASSERT_TRUE(project(tag[k], &px));
      const auto edge = TagEdgeCornerPixel(project, tag, k);
      ASSERT_TRUE(edge.has_value());
      EXPECT_LT((*edge - px).norm(), 1e-9) << "pinhole, corner " << k;
    }
    // The default virtual Owl's left lens (k1 -0.118, k2 0.092, k3 -0.021): barrel.
    s.cam.params[4] = -0.118;
    s.cam.params[5] = 0.092;
    s.cam.params[8] = -0.021;
    for (int k = 0; k < 4; ++k) {
      Eigen::Vector2d px;
      ASSERT_TRUE(project(tag[k], &px));
      const auto edge = TagEdgeCornerPixel(project, tag, k);
      ASSERT_TRUE(edge.has_value());
      const Eigen::Vector2d out = (px - Eigen::Vector2d(322.8, 236.1)).normalized();
      const double radial = (*edge - px).dot(out);
      EXPECT_GT(radial, 0.003) << "corner " << k << " at " << px.transpose();
      EXPECT_LT(radial, 0.1) << "corner " << k << " at " << px.transpose();
    }
  }
  EXPECT_FALSE(TagEdgeCornerPixel(project, tag, 4).has_value());
  auto behind = [&](const Eigen::Vector3d&, Eigen::Vector2d*) { return false; };
  EXPECT_FALSE(TagEdgeCornerPixel(behind, tag, 0).has_value());
}

}  // namespace
}  // namespace owlcal::fitting
