#include "calib/lk_tracker.h"

#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "io/number_text.h"

namespace owlcal::calib {
namespace {

cv::Mat LkGrey(const cv::Mat& image) {
  if (image.channels() == 1) return image;
  cv::Mat g;
  cv::cvtColor(image, g, cv::COLOR_BGR2GRAY);
  return g;
}

// A window_px square patch centred on px (sub-pixel, bilinear), as float.
cv::Mat Patch(const cv::Mat& grey, const Eigen::Vector2d& px, int window_px) {
  cv::Mat p;
  cv::getRectSubPix(grey, cv::Size(window_px, window_px), cv::Point2f(float(px.x()), float(px.y())), p, CV_32F);
  return p;
}

// Normalised cross-correlation of two equal patches (-1..1; 0 when either is flat).
double Ncc(const cv::Mat& a, const cv::Mat& b) {
  cv::Scalar ma, sa, mb, sb;
  cv::meanStdDev(a, ma, sa);
  cv::meanStdDev(b, mb, sb);
  if (sa[0] < 1e-6 || sb[0] < 1e-6) return 0;
  cv::Mat da = a - ma[0], db = b - mb[0];
  return da.dot(db) / (double(a.total()) * sa[0] * sb[0]);
}

bool Inside(const Eigen::Vector2d& px, const cv::Mat& img, double margin) {
  return px.x() >= margin && px.y() >= margin && px.x() <= img.cols - 1 - margin && px.y() <= img.rows - 1 - margin;
}

std::string Px(const Eigen::Vector2d& p) {
  std::string s = "(";
  s += io::FixedText(p.x(), 1);
  s += ", ";
  s += io::FixedText(p.y(), 1);
  s += ")";
  return s;
}

}  // namespace

double PatchNcc(
    const cv::Mat& a, const Eigen::Vector2d& pa, const cv::Mat& b, const Eigen::Vector2d& pb, int window_px) {
  return Ncc(Patch(LkGrey(a), pa, window_px), Patch(LkGrey(b), pb, window_px));
}

bool LkTrackerOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = "LK tracker options: " + m;
    return false;
  };
  if (window_px < 5 || window_px % 2 == 0) return fail("window_px must be odd and >= 5");
  if (pyramid_levels < 0 || pyramid_levels > 6) return fail("pyramid_levels must be in [0, 6]");
  if (!(max_fb_error_px > 0)) return fail("max_fb_error_px must be > 0");
  if (!(max_refine_px > 0)) return fail("max_refine_px must be > 0");
  if (!(min_ncc > -1 && min_ncc < 1)) return fail("min_ncc must be in (-1, 1)");
  if (!(min_reacquire_ncc > -1 && min_reacquire_ncc < 1)) return fail("min_reacquire_ncc must be in (-1, 1)");
  if (reacquire_window_px < 5 || reacquire_window_px % 2 == 0) return fail("reacquire_window_px must be odd and >= 5");
  if (!(min_texture >= 0)) return fail("min_texture must be >= 0");
  return true;
}

void LkTracker::Stop(const std::string& reason) {
  tracking_ = false;
  lost_reason_ = reason;
}

bool LkTracker::Start(const cv::Mat& image, const Eigen::Vector2d& px, std::string* why) {
  tracking_ = false;
  auto fail = [&](const std::string& m) {
    lost_reason_ = m;
    if (why) *why = m;
    return false;
  };
  std::string w;
  if (!options_.Check(&w)) return fail(w);
  if (image.empty()) return fail("LK tracker: empty image at start");
  const cv::Mat g = LkGrey(image);
  const double half = options_.window_px / 2;
  if (!Inside(px, g, half)) return fail("LK tracker: start point " + Px(px) + " within half a window of the border");
  cv::Scalar m, sd;
  cv::meanStdDev(Patch(g, px, options_.window_px), m, sd);
  if (sd[0] < options_.min_texture)
    return fail("LK tracker: no texture to track at " + Px(px) + " (grey sd " + io::FixedText(sd[0], 2) + ")");
  ref_ = g.clone();
  prev_ = ref_;
  ref_px_ = px_ = px;
  tracking_ = true;
  lost_reason_.clear();
  return true;
}

bool LkTracker::Resume(const cv::Mat& image, const Eigen::Vector2d& px, std::string* why) {
  if (ref_.empty()) {
    if (why) *why = "LK tracker: no reference to resume from (never started)";
    return false;
  }
  const cv::Mat ref = ref_;
  const Eigen::Vector2d ref_px = ref_px_;
  if (!Start(image, px, why)) return false;
  // Back to the first reference, refined from it to this image.
  ref_ = ref;
  ref_px_ = ref_px;
  const cv::Mat g = prev_;
  std::vector<cv::Point2f> r0 = {cv::Point2f(float(ref_px_.x()), float(ref_px_.y()))};
  std::vector<cv::Point2f> r1 = {cv::Point2f(float(px.x()), float(px.y()))};
  std::vector<uchar> st;
  std::vector<float> err;
  const cv::TermCriteria term(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01);
  cv::calcOpticalFlowPyrLK(ref_,
                           g,
                           r0,
                           r1,
                           st,
                           err,
                           cv::Size(options_.window_px, options_.window_px),
                           0,
                           term,
                           cv::OPTFLOW_USE_INITIAL_FLOW);
  const Eigen::Vector2d refined(r1[0].x, r1[0].y);
  if (st[0] && (refined - px).norm() <= options_.max_refine_px) px_ = refined;
  return true;
}

LkUpdate LkTracker::Track(const cv::Mat& image) {
  LkUpdate u;
  if (!tracking_) {
    u.reason = lost_reason_.empty() ? "not tracking" : "lost earlier: " + lost_reason_;
    return u;
  }
  const cv::Mat g = LkGrey(image);
  const cv::Size win(options_.window_px, options_.window_px);
  const cv::TermCriteria term(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01);
  const double half = options_.window_px / 2;
  auto lose = [&](const std::string& reason) {
    Stop(reason);
    u.ok = false;
    u.reason = reason;
    return u;
  };
  // 1. Frame to frame.
  std::vector<cv::Point2f> p0 = {cv::Point2f(float(px_.x()), float(px_.y()))}, p1, back;
  std::vector<uchar> st, st_back;
  std::vector<float> err;
  cv::calcOpticalFlowPyrLK(prev_, g, p0, p1, st, err, win, options_.pyramid_levels, term);
  if (!st[0]) return lose("LK found no flow from " + Px(px_) + " (the point left the image or lost its texture)");
  Eigen::Vector2d next(p1[0].x, p1[0].y);
  // 2. Forward-backward.
  cv::calcOpticalFlowPyrLK(g, prev_, p1, back, st_back, err, win, options_.pyramid_levels, term);
  if (!st_back[0]) return lose("LK found no backward flow from " + Px(next));
  u.fb_error_px = std::hypot(back[0].x - p0[0].x, back[0].y - p0[0].y);
  if (u.fb_error_px > options_.max_fb_error_px)
    return lose("forward-backward error " + io::FixedText(u.fb_error_px, 2) + " px > " +
                io::FixedText(options_.max_fb_error_px, 2) + " px at " + Px(next));
  // 3. Refinement against the reference image (no pyramid: it starts within a pixel or two).
  {
    std::vector<cv::Point2f> r0 = {cv::Point2f(float(ref_px_.x()), float(ref_px_.y()))};
    std::vector<cv::Point2f> r1 = {p1[0]};
    std::vector<uchar> rst;
    cv::calcOpticalFlowPyrLK(ref_, g, r0, r1, rst, err, win, 0, term, cv::OPTFLOW_USE_INITIAL_FLOW);
    const Eigen::Vector2d refined(r1[0].x, r1[0].y);
    if (rst[0] && (refined - next).norm() <= options_.max_refine_px) next = refined;
  }
  // 5. Inside the image (checked before the patch is cut).
  if (!Inside(next, g, half))
    return lose("the target left the image: tracked to " + Px(next) + ", within half a window (" +
                std::to_string(int(half)) + " px) of the border");
  // 4. Appearance.
  u.ncc = Ncc(Patch(ref_, ref_px_, options_.window_px), Patch(g, next, options_.window_px));
  if (u.ncc < options_.min_ncc)
    return lose("the tracked patch no longer looks like the target (NCC " + io::FixedText(u.ncc, 2) + " < " +
                io::FixedText(options_.min_ncc, 2) + " at " + Px(next) + ": occluded or slipped to the background)");
  px_ = next;
  prev_ = g.clone();
  u.ok = true;
  u.px = px_;
  return u;
}

}  // namespace owlcal::calib
