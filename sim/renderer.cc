// EyeRenderer (sim/renderer.h): each pixel's ray against the scene's textured planes (targets,
// moving ones per row for the rolling shutter, and the wall), lens shading, the socket rim and defocus;
// and the sensor noise. The textures: sim/target_texture.cc.
#include "sim/renderer.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>

namespace owlcal::sim {
namespace {

// Pixels per block of a row whose rays' bounding box lets a plane skip the whole block.
constexpr int kRayBlock = 32;

inline uint64_t SplitMix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// Blurs each pixel of `grey` by a Gaussian of its own sigma [px]: the image is blurred at a
// ladder of sigmas (0, 0.25, 0.5, 0.75, 1, 1.5, 2, 3, 4 px; beyond 4 px clamped) up to the
// largest needed, and each pixel interpolates linearly between the two rungs around its
// sigma. A layered approximation: a near surface's blur does not spill over a far one's edge.
void ApplyDefocus(const cv::Mat& sigma, cv::Mat* grey) {
  static constexpr float kRungs[] = {0.f, 0.25f, 0.5f, 0.75f, 1.f, 1.5f, 2.f, 3.f, 4.f};
  constexpr int kNum = int(sizeof kRungs / sizeof kRungs[0]);
  double max_sigma = 0;
  cv::minMaxLoc(sigma, nullptr, &max_sigma);
  if (max_sigma < 0.01) return;
  int top = 1;
  while (top < kNum - 1 && kRungs[top] < max_sigma) ++top;
  std::vector<cv::Mat> rung(size_t(top) + 1);
  grey->convertTo(rung[0], CV_32F);
  for (int r = 1; r <= top; ++r)
    cv::GaussianBlur(rung[0], rung[size_t(r)], cv::Size(0, 0), kRungs[r], kRungs[r], cv::BORDER_REFLECT);
  std::vector<const float*> rows(size_t(top) + 1);
  for (int y = 0; y < grey->rows; ++y) {
    uint8_t* out = grey->ptr<uint8_t>(y);
    const float* s = sigma.ptr<float>(y);
    for (int r = 0; r <= top; ++r) rows[size_t(r)] = rung[size_t(r)].ptr<float>(y);
    for (int x = 0; x < grey->cols; ++x) {
      const float sg = std::min(s[x], kRungs[top]);
      int r = 0;
      while (r + 1 < top && kRungs[r + 1] <= sg) ++r;
      const float f = std::clamp((sg - kRungs[r]) / (kRungs[r + 1] - kRungs[r]), 0.f, 1.f);
      const float a = rows[size_t(r)][x], b = rows[size_t(r) + 1][x];
      out[x] = uint8_t(std::clamp(a + f * (b - a) + 0.5f, 0.f, 255.f));
    }
  }
}

// One textured plane as EyeRenderer::Render intersects it with the pixels' rays.
struct RenderPlane {
  float m[9];            // ray (x, y, 1) -> (u q2, v q2, q2) in level-0 texels
  float x0, x1, y0, y1;  // bounding box in normalised ray coordinates
  float w, h;            // texture size (level-0 texels)
  float lod;
  bool wrap;
  const MipTexture* tex;
  // What SamplePlane reads, fixed by lod: the level (wrap: the nearest; else the one below lod),
  // and for a trilinear blend the level above and its weight.
  MipTexture::LevelView level_a, level_b;
  bool trilinear = false;
  float lod_frac = 0.f;
  // Board warp (SceneTarget::warp_m): ray direction in the target frame (rows of R^T), and
  // the parabola's centre, half spans [texels] and deflections [texels].
  bool warped = false;
  float rt[9];
  float uc, vc, hu, hv, kx, ky;
};

// The plane of a target (or the wall) seen from the camera: the ray -> texel map, the bounding
// box of its rays, the level of detail at its centre and its bow; false when seen edge-on.
bool MakeRenderPlane(const models::Rigid3d& cam_from_base,
                     const Eigen::Isometry3d& base_from_target,
                     const TargetTexture& tt,
                     bool wrap,
                     const Eigen::Vector4d* extent,
                     const SceneTarget* target,
                     double fx,
                     double fy,
                     double blur_px,
                     RenderPlane* out) {
  // cam_from_target = [R | t]; a target point (a, b, 0) is on ray lambda * (x, y, 1) with
  // (x, y, 1) ~ G (a, b, 1), G = [r1 r2 t]. Texture coords (u, v) = s * ((a, b) - origin).
  const Eigen::Matrix4d ct = cam_from_base.Matrix() * base_from_target.matrix();
  Eigen::Matrix3d g;
  g.col(0) = ct.block<3, 1>(0, 0);
  g.col(1) = ct.block<3, 1>(0, 1);
  g.col(2) = ct.block<3, 1>(0, 3);
  if (std::abs(g.determinant()) < 1e-12) return false;  // seen edge-on
  Eigen::Matrix3d s = Eigen::Matrix3d::Identity();
  s(0, 0) = s(1, 1) = tt.texels_per_m;
  s(0, 2) = -tt.texels_per_m * tt.origin_m.x();
  s(1, 2) = -tt.texels_per_m * tt.origin_m.y();
  Eigen::Matrix3d m = s * g.inverse();
  // Normalise so the ray depth is 1 / q2 (q2 = third row . ray > 0 in front).
  // G^-1 (x, y, 1) = (a, b, 1) / lambda already has that scale; s keeps the third row.
  RenderPlane p;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) p.m[3 * r + c] = float(m(r, c));
  p.w = float(tt.texture.width());
  p.h = float(tt.texture.height());
  p.wrap = wrap;
  p.tex = &tt.texture;
  p.x0 = p.y0 = -1e30f;
  p.x1 = p.y1 = 1e30f;
  // Level of detail at the target's centre (or straight ahead for the wall).
  Eigen::Vector3d centre_in_cam(0, 0, 1);
  if (extent) {
    const Eigen::Vector4d& e = *extent;
    bool all_in_front = true;
    float x0 = 1e30f, x1 = -1e30f, y0 = 1e30f, y1 = -1e30f;
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector4d corner(k & 1 ? e[1] : e[0], k & 2 ? e[3] : e[2], 0, 1);
      const Eigen::Vector4d c = ct * corner;
      if (c.z() < 1e-6) {
        all_in_front = false;
        break;
      }
      x0 = std::min(x0, float(c.x() / c.z()));
      x1 = std::max(x1, float(c.x() / c.z()));
      y0 = std::min(y0, float(c.y() / c.z()));
      y1 = std::max(y1, float(c.y() / c.z()));
    }
    if (all_in_front) {
      p.x0 = x0 - 1e-4f;
      p.x1 = x1 + 1e-4f;
      p.y0 = y0 - 1e-4f;
      p.y1 = y1 + 1e-4f;
    }
    centre_in_cam = (ct * Eigen::Vector4d((e[0] + e[1]) / 2, (e[2] + e[3]) / 2, 0, 1)).head<3>();
  }
  float lod = 0.f;
  if (centre_in_cam.z() > 1e-6) {
    const double xn = centre_in_cam.x() / centre_in_cam.z(), yn = centre_in_cam.y() / centre_in_cam.z();
    auto uv = [&](double x, double y) {
      const Eigen::Vector3d q = m * Eigen::Vector3d(x, y, 1);
      return Eigen::Vector2d(q.x() / q.z(), q.y() / q.z());
    };
    const Eigen::Vector2d c = uv(xn, yn);
    const double dx = (uv(xn + 1.0 / fx, yn) - c).norm();
    const double dy = (uv(xn, yn + 1.0 / fy) - c).norm();
    // Optical blur: the lens and the sensor's demosaicing spread a point over more than
    // one pixel; the texture is filtered over blur_px pixels (which also keeps detectors
    // from locking corners to the pixel grid).
    const double tpp = std::max(dx, dy) * blur_px;
    if (std::isfinite(tpp) && tpp > 1.0) lod = float(std::log2(tpp));
  }
  p.lod = std::min(lod, float(tt.texture.num_levels() - 1));
  // The levels MipTexture::Sample (wrap) or SampleLod would pick for this lod.
  if (wrap) {
    p.level_a = tt.texture.View(int(p.lod + 0.5f));
  } else if (p.lod <= 0.f) {
    p.level_a = tt.texture.View(0);
  } else {
    const int l0 = int(p.lod);
    p.lod_frac = p.lod - float(l0);
    p.level_a = tt.texture.View(l0);
    p.trilinear = !(p.lod_frac < 1e-3f || l0 + 1 >= tt.texture.num_levels());
    if (p.trilinear) p.level_b = tt.texture.View(l0 + 1);
  }
  if (target && (target->warp_m.x() != 0 || target->warp_m.y() != 0)) {
    const Eigen::Vector4d span = target->WarpSpan();
    p.warped = true;
    const Eigen::Matrix3d rt = ct.block<3, 3>(0, 0).transpose();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) p.rt[3 * r + c] = float(rt(r, c));
    const double s_t = tt.texels_per_m;
    p.uc = float(s_t * ((span[0] + span[1]) / 2 - tt.origin_m.x()));
    p.vc = float(s_t * ((span[2] + span[3]) / 2 - tt.origin_m.y()));
    p.hu = float(std::max(1e-9, s_t * (span[1] - span[0]) / 2));
    p.hv = float(std::max(1e-9, s_t * (span[3] - span[2]) / 2));
    p.kx = float(s_t * target->warp_m.x());
    p.ky = float(s_t * target->warp_m.y());
  }
  *out = p;
  return true;
}

// Whether the socket rim's ramp reaches the image: true when a sampled border ray comes close to
// its start.
bool RimReachesImage(int width,
                     int height,
                     const std::vector<float>& ray_x,
                     const std::vector<float>& ray_y,
                     const std::vector<float>& inv_norm,
                     float rax,
                     float ray_,
                     float raz,
                     float cos_start) {
  bool rim_active = false;
  for (int i = 0; i < 2 * (width + height) && !rim_active; i += 4) {
    int x, y;
    if (i < width)
      x = i, y = 0;
    else if (i < 2 * width)
      x = i - width, y = height - 1;
    else if (i < 2 * width + height)
      x = 0, y = i - 2 * width;
    else
      x = width - 1, y = i - 2 * width - height;
    const size_t k = size_t(y) * width + x;
    const float c = (rax * ray_x[k] + ray_ * ray_y[k] + raz) * inv_norm[k];
    rim_active = c < cos_start + 0.02f;
  }
  return rim_active;
}

// One image row as EyeRenderer::Render shades it, pixel by pixel: the nearest plane the ray
// hits (-1 for none), its q2 (1 / depth), the texel (u, v) and the texture value t there; per
// tried plane (in the order of the active list) the first and one past the last pixel it won.
struct RowHits {
  std::vector<int> plane;
  std::vector<float> q2, u, v, t;
  std::vector<int> first, last;
  explicit RowHits(int width)
      : plane(size_t(width)), q2(size_t(width)), u(size_t(width)), v(size_t(width)), t(size_t(width)) {}
};

// One plane tried on the pixels [x0, x1) of a row: where the ray (rx, ry, 1) meets it nearer than
// the best hit so far (and inside its texture unless it wraps), it becomes the pixel's hit.
// kBounded: test the plane's bounding box (an unbounded plane's box holds every ray).
template <bool kBounded>
void TryPlaneOnSpan(const RenderPlane& p,
                    int index,
                    const float* rx,
                    const float* ry,
                    int x0,
                    int x1,
                    RowHits* h,
                    int* first,
                    int* last) {
  int* plane = h->plane.data();
  float *best_q2 = h->q2.data(), *bu = h->u.data(), *bv = h->v.data();
  for (int x = x0; x < x1; ++x) {
    if (kBounded && (rx[x] < p.x0 || rx[x] > p.x1 || ry[x] < p.y0 || ry[x] > p.y1)) continue;
    const float q2 = p.m[6] * rx[x] + p.m[7] * ry[x] + p.m[8];
    if (q2 <= best_q2[x]) continue;  // behind the camera or farther than the best hit
    const float inv = 1.f / q2;
    const float u = (p.m[0] * rx[x] + p.m[1] * ry[x] + p.m[2]) * inv;
    const float v = (p.m[3] * rx[x] + p.m[4] * ry[x] + p.m[5]) * inv;
    if (!p.wrap && (u < 0.f || v < 0.f || u >= p.w || v >= p.h)) continue;
    plane[x] = index;
    best_q2[x] = q2;
    bu[x] = u;
    bv[x] = v;
    *first = std::min(*first, x);
    *last = x + 1;
  }
}

// For every pixel of a row, the nearest of the `active` planes its ray hits. The planes are tried
// one after another over the whole row, in the order of `active`, so each pixel sees them in the
// same order as a loop over planes per pixel would (the first of equally near planes wins). A
// bounded plane skips the blocks of kRayBlock pixels whose rays' box (`blocks`: min/max x, min/max
// y per block) misses its own, where every pixel would fail its test.
void NearestPlaneHits(const std::vector<RenderPlane>& planes,
                      const std::vector<int>& active,
                      const float* rx,
                      const float* ry,
                      const float* blocks,
                      int n,
                      RowHits* h) {
  std::fill(h->plane.begin(), h->plane.begin() + n, -1);
  std::fill(h->q2.begin(), h->q2.begin() + n, 0.f);
  std::fill(h->u.begin(), h->u.begin() + n, 0.f);
  std::fill(h->v.begin(), h->v.begin() + n, 0.f);
  h->first.assign(active.size(), n);
  h->last.assign(active.size(), 0);
  for (size_t j = 0; j < active.size(); ++j) {
    const int i = active[j];
    const RenderPlane& p = planes[size_t(i)];
    if (p.x0 == -1e30f && p.x1 == 1e30f && p.y0 == -1e30f && p.y1 == 1e30f) {
      TryPlaneOnSpan<false>(p, i, rx, ry, 0, n, h, &h->first[j], &h->last[j]);
      continue;
    }
    for (int x0 = 0, b = 0; x0 < n; x0 += kRayBlock, ++b) {
      const float* box = blocks + 4 * b;
      if (box[1] < p.x0 || box[0] > p.x1 || box[3] < p.y0 || box[2] > p.y1) continue;
      TryPlaneOnSpan<true>(p, i, rx, ry, x0, std::min(n, x0 + kRayBlock), h, &h->first[j], &h->last[j]);
    }
  }
}

// A bowed board: the texel (u, v) where the ray meets the bowed surface instead of the plane.
void WarpTexel(const RenderPlane& p, float rx, float ry, float* bu, float* bv) {
  // The surface z = -(kx (1 - un^2) + ky (1 - vn^2)) (towards the camera for k > 0):
  // the ray meets it s = z / d_z further along, (u, v) moves by s (d_x, d_y) (first
  // order in the deflection; a second-order error below 0.01 px at millimetre warps).
  const float dx = p.rt[0] * rx + p.rt[1] * ry + p.rt[2];
  const float dy = p.rt[3] * rx + p.rt[4] * ry + p.rt[5];
  const float dz = p.rt[6] * rx + p.rt[7] * ry + p.rt[8];
  if (dz > 1e-6f) {
    const float un = (*bu - p.uc) / p.hu, vn = (*bv - p.vc) / p.hv;
    const float z = -(p.kx * (1.f - un * un) + p.ky * (1.f - vn * vn));
    *bu += z / dz * dx;
    *bv += z / dz * dy;
  }
}

// The texture value t of every pixel of a row whose hit is plane `index`: the bowed board's
// texel first (kWarped), then MipTexture::Sample at the nearest level for the wrapping wall
// (kWrap) or SampleLod's blend of the levels around the plane's lod (kTrilinear: two levels).
template <bool kWarped, bool kWrap, bool kTrilinear>
void SamplePlaneOnRow(const RenderPlane& p, int index, const float* rx, const float* ry, int x0, int x1, RowHits* h) {
  const int* plane = h->plane.data();
  const float *u = h->u.data(), *v = h->v.data();
  float* t = h->t.data();
  for (int x = x0; x < x1; ++x) {
    if (plane[x] != index) continue;
    float bu = u[x], bv = v[x];
    if constexpr (kWarped) WarpTexel(p, rx[x], ry[x], &bu, &bv);
    if constexpr (kWrap) {
      t[x] = MipTexture::SampleView<true>(p.level_a, bu, bv);
    } else {
      const float a = MipTexture::SampleView<false>(p.level_a, bu, bv);
      t[x] = kTrilinear ? a + p.lod_frac * (MipTexture::SampleView<false>(p.level_b, bu, bv) - a) : a;
    }
  }
}

// The texture value of every pixel of a row (0.5 where no plane is hit), one plane at a time
// over the pixels it won.
void SampleRow(const std::vector<RenderPlane>& planes,
               const std::vector<int>& active,
               const float* rx,
               const float* ry,
               int n,
               RowHits* h) {
  std::fill(h->t.begin(), h->t.begin() + n, 0.5f);
  for (size_t j = 0; j < active.size(); ++j) {
    const int i = active[j], x0 = h->first[j], x1 = h->last[j];
    if (x0 >= x1) continue;
    const RenderPlane& p = planes[size_t(i)];
    auto sample = p.wrap ? (p.warped ? SamplePlaneOnRow<true, true, false> : SamplePlaneOnRow<false, true, false>)
                  : p.trilinear
                      ? (p.warped ? SamplePlaneOnRow<true, false, true> : SamplePlaneOnRow<false, false, true>)
                      : (p.warped ? SamplePlaneOnRow<true, false, false> : SamplePlaneOnRow<false, false, false>);
    sample(p, i, rx, ry, x0, x1, h);
  }
}

// Each pixel's defocus sigma [px] (0 where no plane is hit or no ray): DefocusSigmaPx of the hit's
// depth 1 / q2, k = aperture [m] * fx and inv_focus = 1 / focus_m given (the same arithmetic).
void DefocusSigmaRow(const RowHits& h, const float* inv_norm, int n, double k, double inv_focus, float* sigma) {
  for (int x = 0; x < n; ++x) {
    const double depth_m = 1.0 / h.q2[size_t(x)];
    sigma[x] = h.plane[size_t(x)] >= 0 && inv_norm[x] > 0 ? float(k * std::abs(1.0 / depth_m - inv_focus) / 4.0) : 0.f;
  }
}

// The socket rim as Render darkens the image: off when no border ray reaches its ramp.
struct RimShade {
  bool active = false;
  float ax = 0, ay = 0, az = 1;  // the socket axis in the camera frame (unit)
  float cos_start = 0, cos_end = 0, floor = 1;
};

// Grey levels of one row from its texture values: paper/ink levels, lens shading `gain`, the
// socket rim (by each ray's angle from the socket axis), rounded and clamped to 0..255.
void ShadeRow(const float* t,
              const float* gain,
              const float* rx,
              const float* ry,
              const float* inv_norm,
              float black,
              float white,
              const RimShade& rim,
              int n,
              uint8_t* out) {
  for (int x = 0; x < n; ++x) {
    float value = (black + (white - black) * t[x]) * gain[x];
    if (rim.active) {
      const float c = (rim.ax * rx[x] + rim.ay * ry[x] + rim.az) * inv_norm[x];
      if (c < rim.cos_start) {
        // Smooth ramp from 1 at the start angle to rim_floor at the rim.
        float f = (rim.cos_start - c) / std::max(1e-6f, rim.cos_start - rim.cos_end);
        f = std::min(1.f, f);
        f = f * f * (3.f - 2.f * f);
        value *= 1.f - (1.f - rim.floor) * f;
      }
    }
    out[x] = uint8_t(std::clamp(value + 0.5f, 0.f, 255.f));
  }
}

}  // namespace

EyeRenderer::EyeRenderer(const models::CameraIntrinsics& k, const StreamTruth& stream)
    : width_(k.width),
      height_(k.height),
      fx_(k.params[0]),
      fy_(k.params[1]),
      blur_px_(std::max(1.0, stream.blur_px)),
      stream_(stream),
      black_(float(stream.black_level)),
      white_(float(stream.white_level)) {
  const double lens_shading = stream.lens_shading;
  const size_t n = size_t(width_) * height_;
  ray_x_.resize(n);
  ray_y_.resize(n);
  inv_norm_.resize(n);
  gain_.resize(n);
  const double cx = k.params[2], cy = k.params[3];
  const double r_corner2 =
      std::pow(std::max(cx, width_ - 1 - cx) / fx_, 2) + std::pow(std::max(cy, height_ - 1 - cy) / fy_, 2);
  // Unproject pixel by pixel, warm-starting is not needed: Gauss-Newton converges in a few steps.
  for (int y = 0; y < height_; ++y)
    for (int x = 0; x < width_; ++x) {
      const size_t i = size_t(y) * width_ + x;
      const double pix[2] = {double(x), double(y)};
      double ray[3];
      if (!k.Unproject(pix, ray)) {
        // Outside the lens model's valid field: no ray, a dark pixel.
        ray_x_[i] = 1e6f;
        ray_y_[i] = 1e6f;
        inv_norm_[i] = 0;
        gain_[i] = 0;
        continue;
      }
      ray_x_[i] = float(ray[0]);
      ray_y_[i] = float(ray[1]);
      inv_norm_[i] = float(1.0 / std::sqrt(ray[0] * ray[0] + ray[1] * ray[1] + 1.0));
      // Lens shading: brightness falls by `lens_shading` at the image corner, ~ r^2.
      const double pr2 = std::pow((x - cx) / fx_, 2) + std::pow((y - cy) / fy_, 2);
      gain_[i] = float(1.0 - lens_shading * pr2 / r_corner2);
    }
  // Each row's blocks of kRayBlock pixels: the box of their rays (no-ray pixels as stored).
  const int num_blocks = (width_ + kRayBlock - 1) / kRayBlock;
  ray_blocks_.resize(size_t(height_) * 4 * num_blocks);
  for (int y = 0; y < height_; ++y)
    for (int b = 0; b < num_blocks; ++b) {
      float* box = &ray_blocks_[(size_t(y) * num_blocks + b) * 4];
      box[0] = box[2] = 1e30f;
      box[1] = box[3] = -1e30f;
      for (int x = b * kRayBlock; x < std::min(width_, (b + 1) * kRayBlock); ++x) {
        const size_t k = size_t(y) * width_ + x;
        box[0] = std::min(box[0], ray_x_[k]);
        box[1] = std::max(box[1], ray_x_[k]);
        box[2] = std::min(box[2], ray_y_[k]);
        box[3] = std::max(box[3], ray_y_[k]);
      }
    }
  row_ray_y_min_.assign(height_, 1e30f);
  row_ray_y_max_.assign(height_, -1e30f);
  for (int y = 0; y < height_; ++y)
    for (int x = 0; x < width_; ++x) {
      const float ry = ray_y_[size_t(y) * width_ + x];
      if (ry > 1e5f) continue;
      row_ray_y_min_[y] = std::min(row_ray_y_min_[y], ry);
      row_ray_y_max_[y] = std::max(row_ray_y_max_[y], ry);
    }
}

void EyeRenderer::Render(const models::Rigid3d& cam_from_base,
                         const Eigen::Vector3d& rim_axis_in_cam,
                         const SocketTruth& socket,
                         const SceneDescription& scene,
                         const std::vector<const TargetTexture*>& textures,
                         const TargetTexture& background,
                         cv::Mat* grey,
                         cv::Mat* depth_z_m,
                         const RowTiming& timing) const {
  std::vector<RenderPlane> planes;
  auto add_plane = [&](const Eigen::Isometry3d& base_from_target,
                       const TargetTexture& tt,
                       bool wrap,
                       const Eigen::Vector4d* extent,
                       const SceneTarget* target = nullptr) {
    RenderPlane p;
    if (MakeRenderPlane(cam_from_base, base_from_target, tt, wrap, extent, target, fx_, fy_, blur_px_, &p))
      planes.push_back(p);
  };
  // Still targets once; moving ones (rolling shutter) per row below.
  struct Moving {
    const SceneTarget* target;
    const TargetTexture* texture;
    Eigen::Vector4d extent;
  };
  std::vector<Moving> moving;
  for (size_t i = 0; i < scene.targets.size(); ++i) {
    const SceneTarget& t = scene.targets[i];
    if (!t.visible || !textures[i]) continue;
    const TargetTexture& tt = *textures[i];
    const Eigen::Vector4d extent(tt.origin_m.x(),
                                 tt.origin_m.x() + tt.texture.width() / tt.texels_per_m,
                                 tt.origin_m.y(),
                                 tt.origin_m.y() + tt.texture.height() / tt.texels_per_m);
    if (t.motion.Still()) {
      add_plane(t.base_from_target, tt, false, &extent, &t);
    } else {
      moving.push_back({&t, &tt, extent});
    }
  }

  // The background wall: facing the robot at z = distance, texture x along base x, y down.
  Eigen::Isometry3d base_from_wall = Eigen::Isometry3d::Identity();
  base_from_wall.translation() = Eigen::Vector3d(0, 0, scene.background.distance_m);
  add_plane(base_from_wall, background, true, nullptr);
  const size_t num_still = planes.size();

  // Socket rim: darkening once the ray's angle from the socket axis exceeds
  // half_angle - softness; skipped when no image border ray reaches it.
  const Eigen::Vector3d ax = rim_axis_in_cam.normalized();
  RimShade rim;
  rim.ax = float(ax.x());
  rim.ay = float(ax.y());
  rim.az = float(ax.z());
  const double start = (socket.rim_half_angle_deg - socket.rim_softness_deg) * M_PI / 180.0;
  rim.cos_start = float(std::cos(start));
  rim.cos_end = float(std::cos(socket.rim_half_angle_deg * M_PI / 180.0));
  rim.active = RimReachesImage(width_, height_, ray_x_, ray_y_, inv_norm_, rim.ax, rim.ay, rim.az, rim.cos_start);
  rim.floor = float(socket.rim_floor);

  grey->create(height_, width_, CV_8U);
  if (depth_z_m) depth_z_m->create(height_, width_, CV_32F);
  std::vector<int> active;
  active.reserve(planes.size());
  RowHits hits(width_);
  const int num_blocks = (width_ + kRayBlock - 1) / kRayBlock;
  // Per-pixel defocus sigma (only when the lens has an aperture).
  const bool defocus = stream_.aperture_mm > 0;
  cv::Mat defocus_sigma;
  if (defocus) defocus_sigma.create(height_, width_, CV_32F);
  // DefocusSigmaPx's factors: aperture * fx and 1 / focus.
  const double defocus_k = stream_.aperture_mm * 1e-3 * fx_, defocus_inv_focus = 1.0 / stream_.focus_m;
  // Row by row, in passes over the row (hits, texture, depth, shading): short loops whose pixels
  // are independent, with the same arithmetic per pixel as one loop over the pixels.
  for (int y = 0; y < height_; ++y) {
    const size_t row = size_t(y) * width_;
    if (!moving.empty()) {
      planes.resize(num_still);
      const int64_t t_row = timing.exposure_ns + int64_t(std::llround(y * timing.row_ns));
      for (const Moving& m : moving) add_plane(m.target->PoseAt(t_row), *m.texture, false, &m.extent, m.target);
    }
    // Planes whose bounding box meets this row's range of rays.
    active.clear();
    for (int i = 0; i < int(planes.size()); ++i)
      if (planes[i].y0 <= row_ray_y_max_[y] && planes[i].y1 >= row_ray_y_min_[y]) active.push_back(i);
    const float *rx = &ray_x_[row], *ry = &ray_y_[row], *inv_norm = &inv_norm_[row];
    NearestPlaneHits(planes, active, rx, ry, &ray_blocks_[size_t(y) * 4 * num_blocks], width_, &hits);
    SampleRow(planes, active, rx, ry, width_, &hits);
    // The hit point is lambda * (rx, ry, 1) with lambda = 1 / q2: its camera z is 1 / q2.
    if (depth_z_m) {
      float* depth_out = depth_z_m->ptr<float>(y);
      for (int x = 0; x < width_; ++x)
        depth_out[x] = hits.plane[size_t(x)] >= 0 && inv_norm[x] > 0 ? 1.f / hits.q2[size_t(x)]
                                                                     : std::numeric_limits<float>::quiet_NaN();
    }
    if (defocus) DefocusSigmaRow(hits, inv_norm, width_, defocus_k, defocus_inv_focus, defocus_sigma.ptr<float>(y));
    ShadeRow(hits.t.data(), &gain_[row], rx, ry, inv_norm, black_, white_, rim, width_, grey->ptr<uint8_t>(y));
  }
  if (defocus) ApplyDefocus(defocus_sigma, grey);
}

double DefocusSigmaPx(const StreamTruth& stream, double fx, double depth_m) {
  if (!(stream.aperture_mm > 0) || !(depth_m > 0)) return 0;
  return stream.aperture_mm * 1e-3 * fx * std::abs(1.0 / depth_m - 1.0 / stream.focus_m) / 4.0;
}

void AddSensorNoise(cv::Mat* grey, double sigma, uint64_t seed, uint64_t stream) {
  if (sigma <= 0) return;
  // Sum of four uniform bytes: mean 510, standard deviation sqrt(4 * (256^2 - 1) / 12).
  const float scale = float(sigma / std::sqrt(4.0 * (256.0 * 256.0 - 1.0) / 12.0));
  uint64_t counter = SplitMix64(seed * 0x9E3779B97F4A7C15ull ^ SplitMix64(stream));
  for (int y = 0; y < grey->rows; ++y) {
    uint8_t* p = grey->ptr<uint8_t>(y);
    for (int x = 0; x < grey->cols; x += 2) {
      const uint64_t r = SplitMix64(counter++);
      for (int h = 0; h < 2 && x + h < grey->cols; ++h) {
        const uint32_t w = uint32_t(r >> (32 * h));
        const int sum = int(w & 255) + int((w >> 8) & 255) + int((w >> 16) & 255) + int(w >> 24);
        const float v = float(p[x + h]) + (float(sum) - 510.f) * scale;
        p[x + h] = uint8_t(std::clamp(v + 0.5f, 0.f, 255.f));
      }
    }
  }
}

}  // namespace owlcal::sim
