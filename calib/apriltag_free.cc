#include "calib/apriltag_free.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <stdexcept>
#include <tuple>

#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

extern "C" {
#include <apriltag/apriltag.h>
#include <apriltag/tag16h5.h>
#include <apriltag/tag25h9.h>
#include <apriltag/tag36h10.h>
#include <apriltag/tag36h11.h>
#include <apriltag/tagCircle21h7.h>
#include <apriltag/tagCircle49h12.h>
#include <apriltag/tagCustom48h12.h>
#include <apriltag/tagStandard41h12.h>
#include <apriltag/tagStandard52h13.h>
}

namespace owlcal::calib {
namespace {

struct FamilyEntry {
  const char* name;
  apriltag_family_t* (*create)();
  void (*destroy)(apriltag_family_t*);
  bool large;  // more than 10000 codes: 2-bit correction tables would take gigabytes
};

const FamilyEntry kFamilies[] = {
    {"tag36h11", tag36h11_create, tag36h11_destroy, false},
    {"tag36h10", tag36h10_create, tag36h10_destroy, false},
    {"tag25h9", tag25h9_create, tag25h9_destroy, false},
    {"tag16h5", tag16h5_create, tag16h5_destroy, false},
    {"tagCircle21h7", tagCircle21h7_create, tagCircle21h7_destroy, false},
    {"tagCircle49h12", tagCircle49h12_create, tagCircle49h12_destroy, true},
    {"tagCustom48h12", tagCustom48h12_create, tagCustom48h12_destroy, true},
    {"tagStandard41h12", tagStandard41h12_create, tagStandard41h12_destroy, false},
    {"tagStandard52h13", tagStandard52h13_create, tagStandard52h13_destroy, true},
};

const FamilyEntry* FindFamily(const std::string& name) {
  for (const auto& f : kFamilies)
    if (name == f.name) return &f;
  return nullptr;
}

std::vector<std::string> Expand(const std::vector<std::string>& families) {
  std::vector<std::string> out;
  for (const auto& f : families) {
    if (f == "all") {
      for (const auto& e : kFamilies) out.push_back(e.name);
    } else {
      out.push_back(f);
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

// One libapriltag detector per thread and (families, max_hamming), with its families.
struct CachedDetector {
  apriltag_detector_t* detector = nullptr;
  std::vector<std::pair<apriltag_family_t*, void (*)(apriltag_family_t*)>> families;
  ~CachedDetector() {
    if (detector) apriltag_detector_destroy(detector);
    for (auto& [f, destroy] : families) destroy(f);
  }
};

CachedDetector& GetDetector(const std::vector<std::string>& families, int max_hamming) {
  thread_local std::map<std::pair<std::vector<std::string>, int>, std::unique_ptr<CachedDetector>> cache;
  auto& slot = cache[{families, max_hamming}];
  if (!slot) {
    auto d = std::make_unique<CachedDetector>();
    d->detector = apriltag_detector_create();
    d->detector->nthreads = 1;
    for (const auto& name : families) {
      const FamilyEntry* e = FindFamily(name);
      apriltag_family_t* f = e->create();
      d->families.push_back({f, e->destroy});
      apriltag_detector_add_family_bits(d->detector, f, max_hamming);
    }
    slot = std::move(d);
  }
  return *slot;
}

cv::Mat ToGrey8(const cv::Mat& image) {
  if (image.empty()) throw std::invalid_argument("DetectAprilTags: empty image");
  cv::Mat g;
  if (image.channels() == 3)
    cv::cvtColor(image, g, cv::COLOR_BGR2GRAY);
  else if (image.channels() == 4)
    cv::cvtColor(image, g, cv::COLOR_BGRA2GRAY);
  else
    g = image;
  if (g.depth() != CV_8U) {
    cv::Mat g8;
    g.convertTo(g8, CV_8U);
    g = g8;
  }
  return g.isContinuous() ? g : g.clone();
}

// Bilinear grey level at (x, y) (OpenCV convention); false outside the image.
bool Sample(const cv::Mat& g, double x, double y, double* v) {
  if (!(x >= 0 && y >= 0 && x <= g.cols - 1 && y <= g.rows - 1)) return false;
  const int x0 = std::min(static_cast<int>(x), g.cols - 2), y0 = std::min(static_cast<int>(y), g.rows - 2);
  const double fx = x - x0, fy = y - y0;
  const uint8_t* r0 = g.ptr<uint8_t>(y0);
  const uint8_t* r1 = g.ptr<uint8_t>(y0 + 1);
  *v = (1 - fy) * ((1 - fx) * r0[x0] + fx * r0[x0 + 1]) + fy * ((1 - fx) * r1[x0] + fx * r1[x0 + 1]);
  return true;
}

// A line n . x = d (|n| = 1) through points, by total least squares; false if degenerate.
bool FitLine(const std::vector<Eigen::Vector2d>& pts, Eigen::Vector2d* n, double* d) {
  if (pts.size() < 2) return false;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& p : pts) mean += p;
  mean /= static_cast<double>(pts.size());
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  for (const auto& p : pts) cov += (p - mean) * (p - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(cov);
  *n = es.eigenvectors().col(0);  // smallest eigenvalue: the normal
  *d = n->dot(mean);
  return es.eigenvalues()(1) > 0;
}

// Refits one edge from a to b (outward normal `out`, cell size `cell_px`); false when the
// edge has too few usable profiles.
bool RefitEdge(const cv::Mat& g,
               const Eigen::Vector2d& a,
               const Eigen::Vector2d& b,
               const Eigen::Vector2d& out,
               double cell_px,
               Eigen::Vector2d* n,
               double* d) {
  const double len = (b - a).norm();
  const Eigen::Vector2d t = (b - a) / len;
  const double h = std::clamp(0.45 * cell_px, 1.0, 6.0);
  constexpr double kStep = 0.2;
  const int m = static_cast<int>(std::floor(h / kStep));
  std::vector<Eigen::Vector2d> pts;
  std::vector<double> prof(2 * m + 1);
  for (double s = 0.1 * len; s <= 0.9 * len; s += 0.5) {
    const Eigen::Vector2d base = a + s * t;
    bool inside = true;
    for (int i = -m; i <= m && inside; ++i) {
      const Eigen::Vector2d q = base + i * kStep * out;
      inside = Sample(g, q.x(), q.y(), &prof[i + m]);
    }
    if (!inside) continue;
    const double lo_side = (prof[0] + prof[1] + prof[2]) / 3;                      // inside the quad
    const double hi_side = (prof[2 * m] + prof[2 * m - 1] + prof[2 * m - 2]) / 3;  // outside
    if (std::abs(hi_side - lo_side) < 20) continue;                                // no edge here (grey levels)
    // Edge offset from the profile's integral: with w the grey level scaled to 0 inside and 1
    // outside, a step at e gives integral_{-h}^{h} w ds = h - e, whatever the (symmetric) blur
    // or the area sampling; exact for pixel-aligned edges, where a mid-level crossing of the
    // interpolated profile is biased by up to 0.15 px. Trapezoid rule over the samples.
    double area = 0;
    for (int i = 0; i < 2 * m; ++i)
      area += 0.5 * ((prof[i] - lo_side) + (prof[i + 1] - lo_side)) / (hi_side - lo_side) * kStep;
    const double best = m * kStep - area;
    if (std::abs(best) > 0.8 * h) continue;
    pts.push_back(base + best * out);
  }
  if (pts.size() < 6 || !FitLine(pts, n, d)) return false;
  // One rejection pass at 3 robust sigma (floor 0.05 px).
  std::vector<double> r;
  for (const auto& p : pts) r.push_back(std::abs(n->dot(p) - *d));
  std::vector<double> sr = r;
  std::nth_element(sr.begin(), sr.begin() + sr.size() / 2, sr.end());
  const double thr = 3 * std::max(0.05, 1.4826 * sr[sr.size() / 2]);
  std::vector<Eigen::Vector2d> kept;
  for (size_t i = 0; i < pts.size(); ++i)
    if (r[i] <= thr) kept.push_back(pts[i]);
  return kept.size() >= 6 && FitLine(kept, n, d);
}

// owlcal's corner refinement (header): corners in our order, OpenCV convention.
bool RefineCorners(const cv::Mat& g, double quad_cells, std::array<Eigen::Vector2d, 4>* c) {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  for (const auto& p : *c) centre += p / 4;
  Eigen::Vector2d n[4];
  double d[4];
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d& a = (*c)[k];
    const Eigen::Vector2d& b = (*c)[(k + 1) % 4];
    Eigen::Vector2d out(-(b - a).y(), (b - a).x());
    out.normalize();
    if (out.dot(0.5 * (a + b) - centre) < 0) out = -out;
    if (!RefitEdge(g, a, b, out, (b - a).norm() / quad_cells, &n[k], &d[k])) return false;
  }
  std::array<Eigen::Vector2d, 4> r;
  for (int k = 0; k < 4; ++k) {
    // Corner k joins edge k-1 (from corner k-1 to k) and edge k (from k to k+1).
    const int e0 = (k + 3) % 4, e1 = k;
    Eigen::Matrix2d A;
    A << n[e0].transpose(), n[e1].transpose();
    if (std::abs(A.determinant()) < 1e-6) return false;
    r[k] = A.inverse() * Eigen::Vector2d(d[e0], d[e1]);
    if ((r[k] - (*c)[k]).norm() > 1.5) return false;  // not the same corner: keep the library's
  }
  *c = r;
  return true;
}

}  // namespace

std::vector<std::string> AprilTagFamilyNames() {
  std::vector<std::string> out;
  for (const auto& f : kFamilies) out.push_back(f.name);
  return out;
}

void AprilTagQuadCells(const std::string& family, double* first_cell, double* last_cell, int* total_width) {
  const FamilyEntry* e = FindFamily(family);
  if (!e) throw std::invalid_argument("AprilTag family '" + family + "' is not one libapriltag 3.3 ships");
  apriltag_family_t* f = e->create();
  const double b = (f->total_width - f->width_at_border) / 2.0;
  *first_cell = b;
  *last_cell = b + f->width_at_border;
  *total_width = f->total_width;
  e->destroy(f);
}

bool AprilTagOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (families.empty()) return fail("families: none given (e.g. tag36h11, or all)");
  for (const auto& name : Expand(families)) {
    const FamilyEntry* e = FindFamily(name);
    if (!e) {
      std::string known;
      for (const auto& f : kFamilies) known += std::string(known.empty() ? "" : ", ") + f.name;
      return fail("families: '" + name + "' is not an AprilTag family libapriltag 3.3 ships (" + known + ", all)");
    }
    if (e->large && max_hamming > 1)
      return fail("max_hamming = " + std::to_string(max_hamming) + " for " + name +
                  ": the 2-bit decode table of a family this large does not fit in memory; use 0 or 1");
  }
  if (!(quad_decimate >= 1.0 && quad_decimate <= 8.0))
    return fail("quad_decimate = " + std::to_string(quad_decimate) + " must be in 1..8");
  if (!(quad_sigma >= 0 && quad_sigma <= 10))
    return fail("quad_sigma = " + std::to_string(quad_sigma) + " must be in 0..10");
  if (!(decode_sharpening >= 0 && decode_sharpening <= 2))
    return fail("decode_sharpening = " + std::to_string(decode_sharpening) + " must be in 0..2");
  if (max_hamming < 0 || max_hamming > 2) return fail("max_hamming = " + std::to_string(max_hamming) + " must be 0..2");
  if (!(min_decision_margin >= 0))
    return fail("min_decision_margin = " + std::to_string(min_decision_margin) + " must be >= 0");
  return true;
}

std::vector<AprilTagDetection> DetectAprilTags(const cv::Mat& image, const AprilTagOptions& o) {
  std::string why;
  if (!o.Check(&why)) throw std::invalid_argument("AprilTagOptions: " + why);
  const cv::Mat g = ToGrey8(image);
  CachedDetector& cd = GetDetector(Expand(o.families), o.max_hamming);
  cd.detector->quad_decimate = static_cast<float>(o.quad_decimate);
  cd.detector->quad_sigma = static_cast<float>(o.quad_sigma);
  cd.detector->refine_edges = o.refine_edges;
  cd.detector->decode_sharpening = o.decode_sharpening;
  image_u8_t im{g.cols, g.rows, static_cast<int>(g.step[0]), g.data};
  zarray_t* found = apriltag_detector_detect(cd.detector, &im);
  std::vector<AprilTagDetection> out;
  for (int i = 0; i < zarray_size(found); ++i) {
    apriltag_detection_t* det = nullptr;
    zarray_get(found, i, &det);
    if (det->decision_margin < o.min_decision_margin || det->hamming > o.max_hamming) continue;
    AprilTagDetection t;
    t.family = det->family->name;
    t.id = det->id;
    t.hamming = det->hamming;
    t.decision_margin = det->decision_margin;
    // Library order BL, BR, TR, TL -> ours TL, TR, BR, BL; (0,0) at a pixel's corner -> centre.
    for (int k = 0; k < 4; ++k) t.library_corners[k] = Eigen::Vector2d(det->p[3 - k][0] - 0.5, det->p[3 - k][1] - 0.5);
    t.corners = t.library_corners;
    t.centre = Eigen::Vector2d(det->c[0] - 0.5, det->c[1] - 0.5);
    if (o.refine_corners) {
      t.corners_refined = RefineCorners(g, det->family->width_at_border, &t.corners);
      if (t.corners_refined) {
        // Centre: the intersection of the refined quad's diagonals (the tag centre's image).
        Eigen::Matrix2d A;
        A.col(0) = t.corners[2] - t.corners[0];
        A.col(1) = t.corners[1] - t.corners[3];
        if (std::abs(A.determinant()) > 1e-9) {
          const Eigen::Vector2d st = A.inverse() * (t.corners[3] - t.corners[0]);
          t.centre = t.corners[0] + st[0] * (t.corners[2] - t.corners[0]);
        }
      }
    }
    out.push_back(t);
  }
  apriltag_detections_destroy(found);
  std::sort(out.begin(), out.end(), [](const AprilTagDetection& a, const AprilTagDetection& b) {
    return std::make_tuple(a.family, a.id, a.centre.y(), a.centre.x()) <
           std::make_tuple(b.family, b.id, b.centre.y(), b.centre.x());
  });
  std::map<std::pair<std::string, int>, int> count;
  for (const auto& t : out) ++count[{t.family, t.id}];
  for (auto& t : out) {
    t.id_count = count[{t.family, t.id}];
    t.repeated_id = t.id_count > 1;
  }
  return out;
}

}  // namespace owlcal::calib
