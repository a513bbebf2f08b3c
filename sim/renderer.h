#pragma once
// Renders what one eye of the virtual Owl sees: the scene's targets and background wall,
// the eye-socket rim, lens shading. Geometry uses exactly models::HeadModel's projection:
// each pixel's undistorted ray is precomputed once with CameraIntrinsics::Unproject (the
// inverse of Project), so a scene point lands on the pixel HeadModel::Project gives.
//
// Per frame, each target plane maps rays to texture coordinates by one homography
// (q = M * (x, y, 1), u = q0/q2, v = q1/q2, the ray depth is 1/q2); the nearest hit is
// sampled from a mip-mapped, area-averaged texture (trilinear), so edges are antialiased
// and chessboard corners (which sit on texel boundaries at every used level) stay exact.
//
// Pixel values: 0..255 grey, before noise: a texture value t in [0, 1] (0 ink, 1 paper) becomes
// black_level + (white_level - black_level) * t, times the lens shading and the socket rim.
//
// Rolling shutter: row y is exposed at exposure_ns + y * row_ns (RowTiming). A moving target
// (SceneTarget::motion) is drawn at its pose at each row's time, so a held board is sheared
// and stretched as a real rolling-shutter sensor sees it; still targets and the camera pose
// are those of the frame.
#include <algorithm>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "models/head_model.h"
#include "models/rigid3.h"
#include "sim/robot_truth.h"
#include "sim/scene.h"

namespace owlcal::sim {

// A mip-mapped grey texture. Texel (i, j) of level 0 covers [i, i+1) x [j, j+1) in texel
// units; level L halves the resolution by 2x2 area averages.
class MipTexture {
 public:
  MipTexture() = default;
  // level0: CV_32F, values 0..1. wrap: repeat (sizes must be powers of two), else clamp.
  MipTexture(const cv::Mat& level0, bool wrap);
  int width() const { return width_; }
  int height() const { return height_; }
  int num_levels() const { return int(levels_.size()); }
  // Bilinear sample at level `level` of level-0 texel coordinates (u, v).
  float Sample(float u, float v, int level) const;
  // Trilinear sample for level of detail `lod` (log2 of level-0 texels per pixel).
  float SampleLod(float u, float v, float lod) const;

  // One level as the renderer's inner loop reads it: w x h texels, row-major; scale = 2^-level
  // (level-0 texel coordinates to this level's).
  struct LevelView {
    const float* texels = nullptr;
    int w = 0, h = 0;
    float scale = 1.f;
  };
  LevelView View(int level) const;  // level clamped to the pyramid
  // Bilinear sample of one level at level-0 texel coordinates (u, v), repeating (kWrap) or
  // clamping at the edges: the same arithmetic as Sample, inline for the renderer.
  template <bool kWrap>
  [[gnu::always_inline]] static inline float SampleView(const LevelView& l, float u, float v);

 private:
  struct Level {
    int w, h;
    std::vector<float> texels;
  };
  std::vector<Level> levels_;
  int width_ = 0, height_ = 0;
  bool wrap_ = false;
};

template <bool kWrap>
inline float MipTexture::SampleView(const LevelView& l, float u, float v) {
  // Texel centres sit at integer + 0.5.
  const float su = u * l.scale - 0.5f, sv = v * l.scale - 0.5f;
  // floor without the libm call (coordinates are far inside the int range).
  int x0 = int(su), y0 = int(sv);
  x0 -= su < float(x0);
  y0 -= sv < float(y0);
  const float ax = su - float(x0), ay = sv - float(y0);
  int x1 = x0 + 1, y1 = y0 + 1;
  if constexpr (kWrap) {
    x0 &= l.w - 1;
    x1 &= l.w - 1;
    y0 &= l.h - 1;
    y1 &= l.h - 1;
  } else {
    x0 = std::clamp(x0, 0, l.w - 1);
    x1 = std::clamp(x1, 0, l.w - 1);
    y0 = std::clamp(y0, 0, l.h - 1);
    y1 = std::clamp(y1, 0, l.h - 1);
  }
  const float* r0 = l.texels + size_t(y0) * l.w;
  const float* r1 = l.texels + size_t(y1) * l.w;
  const float top = r0[x0] + ax * (r0[x1] - r0[x0]);
  const float bottom = r1[x0] + ax * (r1[x1] - r1[x0]);
  return top + ay * (bottom - top);
}

// A target's printed pattern as a texture: texels_per_m and the target-frame position of
// texel (0, 0)'s outer corner.
struct TargetTexture {
  MipTexture texture;
  double texels_per_m = 0;
  Eigen::Vector2d origin_m = Eigen::Vector2d::Zero();
};
// Builds the texture of a chessboard (plus a one-square white margin), AprilGrid
// (tag36h11 bitmaps from libapriltag, plus a white margin) or fixation disc.
TargetTexture MakeTargetTexture(const calib::TargetDefinition& def);
// The background wall's periodic random texture.
TargetTexture MakeBackgroundTexture(const Background& background);

// When each image row is exposed (rolling shutter): the top row at exposure_ns, row y at
// exposure_ns + y * row_ns. row_ns = 0: a global shutter.
struct RowTiming {
  int64_t exposure_ns = 0;
  double row_ns = 0;
};

// The defocus of the stream's lens at depth z [m] for a camera of focal length fx [px]: the
// standard deviation [px] of the blur disc (diameter aperture * fx * |1/z - 1/focus|; a
// uniform disc of diameter c has sigma c / 4 along each axis). 0 when aperture_mm = 0.
double DefocusSigmaPx(const StreamTruth& stream, double fx, double depth_m);

class EyeRenderer {
 public:
  // Photometry from the stream truth: lens_shading, blur_px (width of the optical blur, the
  // texture filter footprint, >= 1 px), white_level and black_level.
  EyeRenderer(const models::CameraIntrinsics& intrinsics, const StreamTruth& stream);
  // Renders one 8-bit grey image (no noise). cam_from_base: this eye's camera pose.
  // rim_axis_in_cam: the head's forward axis (socket axis) in the camera frame.
  // depth_z_m (optional): the truth depth of the surface each pixel sees, CV_32F, as the z
  // coordinate [m] in this camera's frame (not the distance along the ray); NaN where the
  // lens model has no ray. The socket rim darkens the image but does not hide the surface.
  // Moving targets are drawn at their pose at each row's exposure time (`timing`).
  // Defocus (stream aperture_mm > 0): each pixel is blurred by a Gaussian of the
  // DefocusSigmaPx of the depth it sees (layered: the image blurred at a ladder of sigmas,
  // blended per pixel), after the texture filter's blur_px.
  void Render(const models::Rigid3d& cam_from_base,
              const Eigen::Vector3d& rim_axis_in_cam,
              const SocketTruth& socket,
              const SceneDescription& scene,
              const std::vector<const TargetTexture*>& textures,  // per scene target
              const TargetTexture& background,
              cv::Mat* grey,
              cv::Mat* depth_z_m = nullptr,
              const RowTiming& timing = {}) const;
  int width() const { return width_; }
  int height() const { return height_; }

 private:
  int width_, height_;
  double fx_, fy_;
  double blur_px_;
  StreamTruth stream_;  // for the defocus
  float black_, white_;
  std::vector<float> ray_x_, ray_y_, inv_norm_, gain_;
  std::vector<float> row_ray_y_min_, row_ray_y_max_;  // per image row
  // Per row, per block of 32 pixels (kRayBlock in the .cc): min and max ray x, min and max ray y.
  std::vector<float> ray_blocks_;
};

// Adds zero-mean, approximately Gaussian noise of sigma grey levels (sum of four uniform
// bytes from a counter-based hash of (seed, stream)), deterministic for its arguments.
void AddSensorNoise(cv::Mat* grey, double sigma, uint64_t seed, uint64_t stream);

}  // namespace owlcal::sim
