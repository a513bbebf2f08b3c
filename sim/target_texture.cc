// The textures the virtual Owl renders: the mip pyramid (MipTexture) with its sampling, each
// target's texture (chessboard, AprilGrid, fixation disc) and the background wall's (sim/renderer.h).
#include "sim/renderer.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>

#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>
#include <opencv2/imgproc.hpp>

namespace owlcal::sim {
namespace {

// Fills the texel rectangle [x0, x1) x [y0, y1) (level-0 texel units, integers) with v.
void FillRect(cv::Mat* m, int x0, int y0, int x1, int y1, float v) {
  x0 = std::max(0, x0);
  y0 = std::max(0, y0);
  x1 = std::min(m->cols, x1);
  y1 = std::min(m->rows, y1);
  if (x1 <= x0 || y1 <= y0) return;
  (*m)(cv::Rect(x0, y0, x1 - x0, y1 - y0)).setTo(v);
}

}  // namespace

MipTexture::MipTexture(const cv::Mat& level0, bool wrap) : width_(level0.cols), height_(level0.rows), wrap_(wrap) {
  if (level0.type() != CV_32F || level0.empty())
    throw std::invalid_argument("MipTexture: level 0 must be a non-empty CV_32F image");
  if (wrap && ((width_ & (width_ - 1)) || (height_ & (height_ - 1)))) {
    throw std::invalid_argument("MipTexture: a wrapping texture needs power-of-two sizes, got " +
                                std::to_string(width_) + "x" + std::to_string(height_));
  }
  Level l0{width_, height_, {}};
  l0.texels.assign(size_t(width_) * height_, 0.f);
  for (int y = 0; y < height_; ++y)
    for (int x = 0; x < width_; ++x) l0.texels[size_t(y) * width_ + x] = level0.at<float>(y, x);
  levels_.push_back(std::move(l0));
  // Level L+1 texel (i, j) = mean of level L texels (2i..2i+1, 2j..2j+1); an odd last
  // column/row is padded with the edge value (clamp) or wraps.
  while (levels_.back().w > 1 || levels_.back().h > 1) {
    const Level& p = levels_.back();
    Level n{(p.w + 1) / 2, (p.h + 1) / 2, {}};
    n.texels.resize(size_t(n.w) * n.h);
    for (int y = 0; y < n.h; ++y) {
      const int y0 = 2 * y, y1 = std::min(2 * y + 1, p.h - 1);
      for (int x = 0; x < n.w; ++x) {
        const int x0 = 2 * x, x1 = std::min(2 * x + 1, p.w - 1);
        n.texels[size_t(y) * n.w + x] = 0.25f * (p.texels[size_t(y0) * p.w + x0] + p.texels[size_t(y0) * p.w + x1] +
                                                 p.texels[size_t(y1) * p.w + x0] + p.texels[size_t(y1) * p.w + x1]);
      }
    }
    levels_.push_back(std::move(n));
    if (levels_.size() > 14) break;
  }
}

MipTexture::LevelView MipTexture::View(int level) const {
  level = std::clamp(level, 0, int(levels_.size()) - 1);
  const Level& l = levels_[size_t(level)];
  return {l.texels.data(), l.w, l.h, 1.f / float(1 << level)};
}

float MipTexture::Sample(float u, float v, int level) const {
  return wrap_ ? SampleView<true>(View(level), u, v) : SampleView<false>(View(level), u, v);
}

float MipTexture::SampleLod(float u, float v, float lod) const {
  if (lod <= 0.f) return Sample(u, v, 0);
  const int l0 = int(lod);
  const float f = lod - float(l0);
  const float a = Sample(u, v, l0);
  if (f < 1e-3f || l0 + 1 >= int(levels_.size())) return a;
  return a + f * (Sample(u, v, l0 + 1) - a);
}

TargetTexture MakeTargetTexture(const calib::TargetDefinition& def) {
  TargetTexture t;
  switch (def.kind) {
    case calib::TargetKind::kChessboard: {
      // 128 texels per square (0.6 px per texel at 0.2 m: the texture, not its resolution,
      // is what a near board shows; farther, the mip levels are the 32-texel board's exactly);
      // squares from -1 .. cols (x) and -1 .. rows (y), inner corners at multiples of the
      // square; one white square of margin all round.
      const int k = 128;
      const int nx = def.cols + 3, ny = def.rows + 3;
      cv::Mat img(ny * k, nx * k, CV_32F, cv::Scalar(1.f));
      for (int j = -1; j < def.rows; ++j)
        for (int i = -1; i < def.cols; ++i)
          if (((i + j) & 1) == 0) FillRect(&img, (i + 2) * k, (j + 2) * k, (i + 3) * k, (j + 3) * k, 0.f);
      t.texels_per_m = k / def.square_m;
      t.origin_m = Eigen::Vector2d(-2 * def.square_m, -2 * def.square_m);
      t.texture = MipTexture(img, false);
      break;
    }
    case calib::TargetKind::kAprilGrid: {
      if (def.family != "tag36h11")
        throw std::invalid_argument("MakeTargetTexture: family '" + def.family + "' (only tag36h11)");
      // Texels per bit: m * 2^k with 8 m (1 + spacing) an integer, so every tag corner lies
      // on a texel boundary; >= 16 texels per bit.
      int m = 1;
      for (int c = 1; c <= 10; ++c) {
        const double p = 8.0 * c * (1.0 + def.tag_spacing);
        if (std::abs(p - std::round(p)) < 1e-6) {
          m = c;
          break;
        }
      }
      int bit = m;
      while (bit < 16) bit *= 2;
      const double bit_m = def.tag_size_m / 8.0;
      t.texels_per_m = bit / bit_m;
      const int pitch = int(std::lround(8.0 * bit * (1.0 + def.tag_spacing)));
      const int margin = int(std::lround(8.0 * bit * def.tag_spacing)) + 2 * bit;  // spacing + 2 bits of paper
      const int w = 2 * margin + (def.tag_cols - 1) * pitch + 8 * bit;
      const int h = 2 * margin + (def.tag_rows - 1) * pitch + 8 * bit;
      cv::Mat img(h, w, CV_32F, cv::Scalar(1.f));
      apriltag_family_t* fam = tag36h11_create();
      for (int r = 0; r < def.tag_rows; ++r)
        for (int c = 0; c < def.tag_cols; ++c) {
          const int id = def.first_id + r * def.tag_cols + c;
          if (id < 0 || id >= int(fam->ncodes)) {
            tag36h11_destroy(fam);
            throw std::invalid_argument("MakeTargetTexture: tag id " + std::to_string(id) + " outside tag36h11");
          }
          image_u8_t* tag = apriltag_to_image(fam, id);
          // tag image: total_width bits with the black border's outer corner at
          // (b, b) = ((total_width - width_at_border) / 2).
          const int b = (fam->total_width - fam->width_at_border) / 2;
          const int x0 = margin + c * pitch - b * bit, y0 = margin + r * pitch - b * bit;
          for (int y = 0; y < tag->height; ++y)
            for (int x = 0; x < tag->width; ++x)
              if (tag->buf[y * tag->stride + x] < 128) {
                FillRect(&img, x0 + x * bit, y0 + y * bit, x0 + (x + 1) * bit, y0 + (y + 1) * bit, 0.f);
              }
          // image_u8_destroy is not exported by Debian's libapriltag; it frees these two.
          free(tag->buf);
          free(tag);
        }
      tag36h11_destroy(fam);
      t.origin_m = Eigen::Vector2d(-margin / t.texels_per_m, -margin / t.texels_per_m);
      t.texture = MipTexture(img, false);
      break;
    }
    case calib::TargetKind::kFixation: {
      // A black disc of radius r on a white square of side 4 r; area coverage by 8x8
      // supersampling per texel.
      const int n = 256;
      const double r = def.fixation_radius_m;
      t.texels_per_m = n / (4 * r);
      t.origin_m = Eigen::Vector2d(-2 * r, -2 * r);
      cv::Mat img(n, n, CV_32F);
      const double rt = r * t.texels_per_m, c = n / 2.0;
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          int inside = 0;
          for (int sy = 0; sy < 8; ++sy)
            for (int sx = 0; sx < 8; ++sx) {
              const double dx = x + (sx + 0.5) / 8 - c, dy = y + (sy + 0.5) / 8 - c;
              inside += dx * dx + dy * dy < rt * rt;
            }
          img.at<float>(y, x) = 1.f - inside / 64.f;
        }
      t.texture = MipTexture(img, false);
      break;
    }
  }
  return t;
}

TargetTexture MakeBackgroundTexture(const Background& bg) {
  // Periodic random texture: a sum of sinusoids with integer frequencies (so it wraps
  // seamlessly) and 1/f amplitudes, plus a few random blobs of constant grey.
  const int n = 512;
  std::mt19937_64 rng(bg.seed);
  std::uniform_real_distribution<double> uni(0, 1);
  cv::Mat img(n, n, CV_32F, cv::Scalar(0.f));
  std::vector<double> row(n);
  for (int k = 0; k < 48; ++k) {
    const int fx = int(uni(rng) * 41) - 20, fy = int(uni(rng) * 41) - 20;
    if (fx == 0 && fy == 0) continue;
    const double f = std::hypot(fx, fy);
    const double amp = 1.0 / f, phase = uni(rng) * 2 * M_PI;
    for (int y = 0; y < n; ++y) {
      float* p = img.ptr<float>(y);
      for (int x = 0; x < n; ++x) p[x] += float(amp * std::sin(2 * M_PI * (fx * x + fy * y) / n + phase));
    }
  }
  cv::Scalar mean, stddev;
  cv::meanStdDev(img, mean, stddev);
  img = (img - mean[0]) * (bg.contrast / 2.0 / std::max(1e-9, stddev[0])) + bg.grey;
  cv::min(img, 1.0, img);
  cv::max(img, 0.0, img);
  TargetTexture t;
  t.texels_per_m = 1.0 / bg.texel_m;
  t.origin_m = Eigen::Vector2d::Zero();
  t.texture = MipTexture(img, true);
  return t;
}

}  // namespace owlcal::sim
