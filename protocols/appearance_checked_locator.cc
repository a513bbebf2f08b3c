#include "protocols/target_locator.h"

#include <algorithm>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "io/number_text.h"

namespace owlcal::protocols {

bool AppearanceCheckOptions::Check(std::string* why) const {
  if (window_px != 0 && (window_px < 5 || window_px % 2 == 0)) {
    if (why) *why = "appearance check: window_px must be 0 (from the target's radius) or odd and >= 5";
    return false;
  }
  if (!(min_ncc > -1 && min_ncc < 1)) {
    if (why) *why = "appearance check: min_ncc must be in (-1, 1)";
    return false;
  }
  return true;
}

AppearanceCheckedLocator::AppearanceCheckedLocator(std::unique_ptr<TargetLocator> inner,
                                                   const AppearanceCheckOptions& options)
    : inner_(std::move(inner)), options_(options) {
  std::string why;
  if (!options_.Check(&why)) throw std::invalid_argument(why);
}

void AppearanceCheckedLocator::ForgetLook() {
  for (int e = 0; e < 2; ++e) {
    look_[e] = templ_[e] = cv::Mat();
    found_[e] = has_last_[e] = false;
    ncc_[e] = NAN;
  }
}

std::optional<Eigen::Vector2d> AppearanceCheckedLocator::Checked(const cv::Mat& image,
                                                                 int eye,
                                                                 const std::optional<Eigen::Vector2d>& p,
                                                                 std::string* why) {
  if (!p) {
    const std::string r = inner_->LastReason(eye);
    *why = "the " + inner_->Name() + " locator found nothing" + (r.empty() ? "" : " (" + r + ")");
    return std::nullopt;
  }
  ncc_[eye] = calib::PatchNcc(look_[eye], look_px_[eye], image, *p, window_px_[eye]);
  if (!(ncc_[eye] >= options_.min_ncc)) {
    *why = "the " + inner_->Name() + " locator's blob at (" + io::FixedText(p->x(), 1) + ", " +
           io::FixedText(p->y(), 1) + ") does not look like the target (NCC " + io::FixedText(ncc_[eye], 2) + " < " +
           io::FixedText(options_.min_ncc, 2) + ")";
    return std::nullopt;
  }
  return p;
}

std::optional<Eigen::Vector2d> AppearanceCheckedLocator::Locate(const cv::Mat& image, int eye) {
  found_[eye] = false;
  reason_[eye].clear();
  ncc_[eye] = NAN;
  std::optional<Eigen::Vector2d> p = inner_->Locate(image, eye);
  if (look_[eye].empty()) {  // the first look
    if (!p) {
      reason_[eye] = inner_->LastReason(eye);
      return std::nullopt;
    }
    cv::Mat g;
    if (image.channels() == 1)
      g = image.clone();
    else
      cv::cvtColor(image, g, cv::COLOR_BGR2GRAY);
    int window = options_.window_px;
    if (window == 0) {
      const std::optional<double> r = inner_->LastRadiusPx(eye);
      window = r && *r > 0 ? std::max(5, 2 * int(std::lround(1.75 * *r - 0.5)) + 1) : 41;
    }
    window_px_[eye] = window;
    const int half = window / 2;
    const Eigen::Vector2d r(std::round(p->x()), std::round(p->y()));
    if (r.x() >= half && r.y() >= half && r.x() < g.cols - half && r.y() < g.rows - half) {
      templ_[eye] = calib::CutTemplate(g, r, half);
      templ_offset_[eye] = *p - r;
    }
    look_[eye] = g;
    look_px_[eye] = last_px_[eye] = *p;
    has_last_[eye] = true;
    ncc_[eye] = 1;
    found_[eye] = true;
    return p;
  }
  std::string why;
  p = Checked(image, eye, p, &why);
  if (p) {
    found_[eye] = has_last_[eye] = true;
    last_px_[eye] = *p;
    return p;
  }
  if (options_.reacquire && !templ_[eye].empty()) {
    // Near the last (or expected) position first: the wall has spots that match a small patch as
    // well as a moving target does; then the whole image.
    std::vector<cv::Rect> areas;
    if (has_last_[eye]) {
      const int reach = 4 * templ_[eye].cols;
      areas.push_back(cv::Rect(int(last_px_[eye].x()) - reach, int(last_px_[eye].y()) - reach, 2 * reach, 2 * reach) &
                      cv::Rect(0, 0, image.cols, image.rows));
    }
    areas.push_back(cv::Rect());
    for (const cv::Rect& area : areas) {
      const calib::TemplateMatch m = calib::MatchTemplateNcc(image, templ_[eye], options_.min_ncc, area);
      const std::string where = area.area() > 0 ? " near its last position" : " in the image";
      if (!m.found) {
        why += "; not found again" + where + " (best NCC " + io::FixedText(m.score, 2) + ")";
        continue;
      }
      inner_->Expect(eye, m.centre + templ_offset_[eye]);
      std::string again;
      p = Checked(image, eye, inner_->Locate(image, eye), &again);
      if (p) {
        found_[eye] = has_last_[eye] = true;
        last_px_[eye] = *p;
        reason_[eye] = "reacquired by NCC " + io::FixedText(m.score, 2) + " after: " + why;
        return p;
      }
      why += "; something like the look (NCC " + io::FixedText(m.score, 2) + ") at (" + io::FixedText(m.centre.x(), 1) +
             ", " + io::FixedText(m.centre.y(), 1) + ")" + where + " but: " + again;
    }
  }
  reason_[eye] = why;
  return std::nullopt;
}

std::unique_ptr<AppearanceCheckedLocator> MakeAppearanceCheckedLocator(std::unique_ptr<TargetLocator> inner,
                                                                       const AppearanceCheckOptions& options) {
  return std::make_unique<AppearanceCheckedLocator>(std::move(inner), options);
}

}  // namespace owlcal::protocols
