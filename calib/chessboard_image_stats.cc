#include "calib/chessboard_image_stats.h"
#include "models/statistics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

namespace owlcal::calib {
namespace {

cv::Mat ToGrey(const cv::Mat& image) {
  if (image.channels() == 1) return image;
  cv::Mat g;
  cv::cvtColor(image, g, image.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
  return g;
}

// Bilinear sample of an 8-bit grey image; NaN outside.
double Sample(const cv::Mat& g, double x, double y) {
  if (!(x >= 0 && y >= 0 && x <= g.cols - 1 && y <= g.rows - 1)) return std::numeric_limits<double>::quiet_NaN();
  const int x0 = std::min(int(x), g.cols - 2), y0 = std::min(int(y), g.rows - 2);
  const double ax = x - x0, ay = y - y0;
  const uint8_t* r0 = g.ptr<uint8_t>(y0);
  const uint8_t* r1 = g.ptr<uint8_t>(y0 + 1);
  const double top = r0[x0] + ax * (r0[x0 + 1] - r0[x0]);
  const double bottom = r1[x0] + ax * (r1[x0 + 1] - r1[x0]);
  return top + ay * (bottom - top);
}

using models::Median;

// Least-squares fit of m + a * erf((d - d0) / (sqrt(2) sigma)) to a profile by Levenberg-
// Marquardt from the plateaus' step; returns sigma (NaN when the step is too weak to mean
// anything or the fit does not settle inside the profile).
double FitErfSigma(const std::vector<double>& d, const std::vector<double>& v) {
  const int n = int(d.size());
  if (n < 8) return std::numeric_limits<double>::quiet_NaN();
  Eigen::Vector4d x(0.5 * (v.front() + v.back()), 0.5 * (v.back() - v.front()), 0.0, 0.6);  // m, a, d0, sigma
  if (std::abs(x(1)) < 10) return std::numeric_limits<double>::quiet_NaN();                 // too little contrast
  auto cost = [&](const Eigen::Vector4d& p) {
    double c = 0;
    for (int i = 0; i < n; ++i) {
      const double r = v[i] - p(0) - p(1) * std::erf((d[i] - p(2)) / (std::sqrt(2.0) * p(3)));
      c += r * r;
    }
    return c;
  };
  double c = cost(x), lambda = 1e-3;
  for (int it = 0; it < 60; ++it) {
    Eigen::Matrix4d jtj = Eigen::Matrix4d::Zero();
    Eigen::Vector4d jtr = Eigen::Vector4d::Zero();
    for (int i = 0; i < n; ++i) {
      const double z = (d[i] - x(2)) / (std::sqrt(2.0) * x(3));
      const double e = std::erf(z), g = 2 / std::sqrt(M_PI) * std::exp(-z * z);
      const Eigen::Vector4d j(1, e, -x(1) * g / (std::sqrt(2.0) * x(3)), -x(1) * g * z / x(3));
      const double r = v[i] - x(0) - x(1) * e;
      jtj += j * j.transpose();
      jtr += j * r;
    }
    Eigen::Matrix4d a = jtj;
    a.diagonal() *= 1 + lambda;
    const Eigen::Vector4d step = a.ldlt().solve(jtr);
    Eigen::Vector4d y = x + step;
    y(3) = std::max(0.05, y(3));
    const double cy = cost(y);
    if (cy < c) {
      const bool done = c - cy < 1e-10 * (1 + c);
      x = y, c = cy, lambda = std::max(1e-9, lambda / 4);
      if (done) break;
    } else {
      lambda *= 8;
      if (lambda > 1e8) break;
    }
  }
  if (!(x(3) > 0.05 && x(3) < 4 && std::abs(x(2)) < 2)) return std::numeric_limits<double>::quiet_NaN();
  return x(3);
}

// One board square between inner corners: its grey level and noise about a fitted plane.
struct BoardSquare {
  double mean;
  Eigen::Vector2d centre;
  double ss;  // residual sum of squares about its plane (clipped)
  int dof;
  int saturated, count;
};

// The square with corners p00 p10 p01 p11: the pixels of its central half (s, t in 0.25-0.75),
// a plane fitted with two rounds of 3-sigma clipping; nullopt when too few pixels remain.
std::optional<BoardSquare> MeasureBoardSquare(const cv::Mat& g,
                                              const Eigen::Vector2d& p00,
                                              const Eigen::Vector2d& p10,
                                              const Eigen::Vector2d& p01,
                                              const Eigen::Vector2d& p11) {
  auto bil = [&](double s, double t) {
    return (1 - s) * (1 - t) * p00 + s * (1 - t) * p10 + (1 - s) * t * p01 + s * t * p11;
  };
  std::vector<cv::Point> poly;
  for (const auto& st : {std::pair{0.25, 0.25}, std::pair{0.75, 0.25}, std::pair{0.75, 0.75}, std::pair{0.25, 0.75}}) {
    const Eigen::Vector2d q = bil(st.first, st.second);
    poly.emplace_back(int(std::lround(q.x())), int(std::lround(q.y())));
  }
  const cv::Rect box = cv::boundingRect(poly) & cv::Rect(0, 0, g.cols, g.rows);
  if (box.area() <= 0) return std::nullopt;
  cv::Mat mask = cv::Mat::zeros(box.size(), CV_8U);
  std::vector<cv::Point> local;
  for (const auto& p : poly) local.emplace_back(p.x - box.x, p.y - box.y);
  cv::fillConvexPoly(mask, local, cv::Scalar(255));
  std::vector<Eigen::Vector3d> px;  // x, y, value
  int sat = 0;
  for (int y = 0; y < box.height; ++y)
    for (int x = 0; x < box.width; ++x) {
      if (!mask.at<uint8_t>(y, x)) continue;
      const int v = g.at<uint8_t>(box.y + y, box.x + x);
      sat += (v >= 255 || v <= 0);
      px.emplace_back(box.x + x, box.y + y, v);
    }
  if (px.size() < 12) return std::nullopt;
  std::vector<bool> keep(px.size(), true);
  double ss = 0;
  int kept = 0;
  double mean = 0;
  for (int round = 0; round < 3; ++round) {
    Eigen::MatrixXd A(px.size(), 3);
    Eigen::VectorXd b(px.size());
    int k = 0;
    for (size_t i = 0; i < px.size(); ++i) {
      if (!keep[i]) continue;
      A.row(k) << 1, px[i].x(), px[i].y();
      b(k) = px[i].z();
      ++k;
    }
    if (k < 8) break;
    const Eigen::Vector3d coef = A.topRows(k).colPivHouseholderQr().solve(b.head(k));
    ss = 0;
    kept = 0;
    mean = 0;
    std::vector<double> res(px.size());
    for (size_t i = 0; i < px.size(); ++i) {
      res[i] = px[i].z() - (coef(0) + coef(1) * px[i].x() + coef(2) * px[i].y());
      if (keep[i]) {
        ss += res[i] * res[i];
        mean += px[i].z();
        ++kept;
      }
    }
    mean /= std::max(1, kept);
    const double sd = std::sqrt(ss / std::max(1, kept - 3));
    if (round == 2) break;
    for (size_t i = 0; i < px.size(); ++i) keep[i] = std::abs(res[i]) <= 3 * sd + 0.5;
  }
  if (kept < 8) return std::nullopt;
  return BoardSquare{mean, 0.25 * (p00 + p10 + p01 + p11), ss, kept - 3, sat, int(px.size())};
}

// The white and black levels and noise (medians over the squares, split at the median level),
// the saturated fraction and the white squares' shading samples into out.
void SquareLevels(const std::vector<BoardSquare>& squares, const cv::Mat& g, ChessboardImageStats* out) {
  std::vector<double> all_means;
  for (const BoardSquare& s : squares) all_means.push_back(s.mean);
  const double split = Median(all_means);
  std::vector<double> whites, blacks;
  std::vector<double> sd[2];
  int sat = 0, count = 0;
  const double cx = (g.cols - 1) / 2.0, cy = (g.rows - 1) / 2.0, rc2 = cx * cx + cy * cy;
  for (const BoardSquare& s : squares) {
    const bool white = s.mean > split;
    (white ? whites : blacks).push_back(s.mean);
    sd[white].push_back(std::sqrt(s.ss / std::max(1, s.dof)));
    sat += s.saturated;
    count += s.count;
    if (white) {
      const Eigen::Vector2d d = (s.centre - Eigen::Vector2d(cx, cy)) / std::sqrt(rc2);
      out->shading.push_back({d.x(), d.y(), s.mean});
    }
  }
  out->white_level = Median(whites);
  out->black_level = Median(blacks);
  out->noise_white = Median(sd[1]);
  out->noise_black = Median(sd[0]);
  out->saturated_fraction = double(sat) / std::max(1, count);
}

// The blur sigma [px] of the edge between neighbouring corners a and b (an erf fitted across its
// middle 40 %); NaN when the edge is shorter than 10 px, leaves the image or the fit fails.
double EdgeBlurSigma(const cv::Mat& g, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double len = (b - a).norm();
  if (len < 10) return nan;
  const Eigen::Vector2d u = (b - a) / len, n(-u.y(), u.x());
  const double reach = std::min(5.0, 0.35 * len);
  std::vector<double> d, v;
  for (double off = -reach; off <= reach + 1e-9; off += 0.25) {
    double sum = 0;
    int k = 0;
    for (double s = 0.3; s <= 0.7001; s += 1.0 / len) {
      const Eigen::Vector2d p = a + s * (b - a) + off * n;
      const double val = Sample(g, p.x(), p.y());
      if (!std::isfinite(val)) continue;
      sum += val;
      ++k;
    }
    if (k == 0) return nan;
    d.push_back(off);
    v.push_back(sum / k);
  }
  return FitErfSigma(d, v);
}

}  // namespace

ChessboardImageStats MeasureChessboardImage(const cv::Mat& image,
                                            const TargetDetection& detection,
                                            const TargetDefinition& target) {
  ChessboardImageStats out;
  if (image.empty()) {
    out.message = "empty image";
    return out;
  }
  if (target.kind != TargetKind::kChessboard) {
    out.message = "target '" + target.id + "' is not a chessboard";
    return out;
  }
  if (!detection.found || int(detection.pixels.size()) != target.cols * target.rows) {
    out.message = "needs a detection with all " + std::to_string(target.cols * target.rows) + " corners";
    return out;
  }
  const cv::Mat g = ToGrey(image);
  if (g.type() != CV_8U) {
    out.message = "needs an 8-bit image";
    return out;
  }
  std::map<int, Eigen::Vector2d> at;
  for (size_t i = 0; i < detection.corner_ids.size(); ++i) at[detection.corner_ids[i]] = detection.pixels[i];
  auto corner = [&](int c, int r) { return at.at(r * target.cols + c); };
  for (int id = 0; id < target.cols * target.rows; ++id)
    if (!at.count(id)) {
      out.message = "corner " + std::to_string(id) + " missing";
      return out;
    }

  // Board area (convex hull of the corners).
  {
    std::vector<cv::Point2f> pts, hull;
    for (const auto& [id, p] : at) pts.emplace_back(float(p.x()), float(p.y()));
    cv::convexHull(pts, hull);
    out.board_area_fraction = cv::contourArea(hull) / (double(g.cols) * g.rows);
  }
  std::vector<BoardSquare> squares;
  for (int r = 0; r + 1 < target.rows; ++r)
    for (int c = 0; c + 1 < target.cols; ++c)
      if (const auto s = MeasureBoardSquare(g, corner(c, r), corner(c + 1, r), corner(c, r + 1), corner(c + 1, r + 1)))
        squares.push_back(*s);
  if (squares.size() < 4) {
    out.message = "board squares too small to measure";
    return out;
  }
  SquareLevels(squares, g, &out);
  // Edges between neighbouring corners (each separates a white and a black square).
  std::vector<double> sigmas;
  auto measure_edge = [&](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    const double s = EdgeBlurSigma(g, a, b);
    if (std::isfinite(s)) sigmas.push_back(s);
  };
  for (int r = 0; r < target.rows; ++r)
    for (int c = 0; c + 1 < target.cols; ++c) measure_edge(corner(c, r), corner(c + 1, r));
  for (int r = 0; r + 1 < target.rows; ++r)
    for (int c = 0; c < target.cols; ++c) measure_edge(corner(c, r), corner(c, r + 1));
  out.num_edges = int(sigmas.size());
  out.edge_sigma_px = Median(sigmas);
  out.ok = true;
  return out;
}

double JpegBlockiness(const cv::Mat& image) {
  const cv::Mat g = ToGrey(image);
  if (g.empty() || g.type() != CV_8U) return std::numeric_limits<double>::quiet_NaN();
  double on = 0, off = 0;
  long n_on = 0, n_off = 0;
  for (int y = 0; y < g.rows; ++y) {
    const uint8_t* p = g.ptr<uint8_t>(y);
    for (int x = 0; x + 1 < g.cols; ++x) {
      const double dd = std::abs(int(p[x + 1]) - int(p[x]));
      if ((x + 1) % 8 == 0)
        on += dd, ++n_on;
      else
        off += dd, ++n_off;
    }
  }
  for (int y = 0; y + 1 < g.rows; ++y) {
    const uint8_t* p = g.ptr<uint8_t>(y);
    const uint8_t* q = g.ptr<uint8_t>(y + 1);
    const bool boundary = (y + 1) % 8 == 0;
    for (int x = 0; x < g.cols; ++x) {
      const double dd = std::abs(int(q[x]) - int(p[x]));
      if (boundary)
        on += dd, ++n_on;
      else
        off += dd, ++n_off;
    }
  }
  if (n_on == 0 || n_off == 0 || off <= 0) return std::numeric_limits<double>::quiet_NaN();
  return (on / n_on) / (off / n_off);
}

int JpegQualityEstimate(const std::vector<unsigned char>& b) {
  // IJG (Annex K) luminance table, natural order, and the zigzag -> natural index map.
  static const int kLuma[64] = {16, 11, 10, 16, 24,  40,  51,  61,  12, 12, 14, 19, 26,  58,  60,  55,
                                14, 13, 16, 24, 40,  57,  69,  56,  14, 17, 22, 29, 51,  87,  80,  62,
                                18, 22, 37, 56, 68,  109, 103, 77,  24, 35, 55, 64, 81,  104, 113, 92,
                                49, 64, 78, 87, 103, 121, 120, 101, 72, 92, 95, 98, 112, 100, 103, 99};
  static const int kZigzag[64] = {0,  1,  8,  16, 9,  2,  3,  10, 17, 24, 32, 25, 18, 11, 4,  5,
                                  12, 19, 26, 33, 40, 48, 41, 34, 27, 20, 13, 6,  7,  14, 21, 28,
                                  35, 42, 49, 56, 57, 50, 43, 36, 29, 22, 15, 23, 30, 37, 44, 51,
                                  58, 59, 52, 45, 38, 31, 39, 46, 53, 60, 61, 54, 47, 55, 62, 63};
  size_t i = 2;
  if (b.size() < 4 || b[0] != 0xFF || b[1] != 0xD8) return -1;
  while (i + 4 <= b.size()) {
    if (b[i] != 0xFF) return -1;
    const int marker = b[i + 1];
    if (marker == 0xD8 || (marker >= 0xD0 && marker <= 0xD7) || marker == 0x01) {
      i += 2;
      continue;
    }
    const size_t len = (size_t(b[i + 2]) << 8) | b[i + 3];
    if (marker == 0xDB && i + 5 + 64 <= b.size()) {
      const int precision = b[i + 4] >> 4;
      int table[64];
      for (int k = 0; k < 64; ++k) {
        table[k] = precision ? ((b[i + 5 + 2 * k] << 8) | b[i + 6 + 2 * k]) : b[i + 5 + k];
      }
      int best_q = -1;
      double best = 1e30;
      for (int q = 1; q <= 100; ++q) {
        const int scale = q < 50 ? 5000 / q : 200 - 2 * q;
        double e = 0;
        for (int k = 0; k < 64; ++k) {
          const int t = std::clamp((kLuma[kZigzag[k]] * scale + 50) / 100, 1, 255);
          e += std::abs(t - table[k]);
        }
        if (e < best) best = e, best_q = q;
      }
      return best_q;
    }
    if (marker == 0xDA) return -1;  // scan started without a table
    i += 2 + len;
  }
  return -1;
}

}  // namespace owlcal::calib
