#include "protocols/live_feedback.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "models/head_kinematics.h"

namespace owlcal::protocols {
namespace {

const char* kParamNames[4] = {"X", "Y", "Size", "Skew"};
constexpr int kBarLeft = 90;  // from the eye column's left edge
constexpr int kBarWidth = 400;
constexpr int kBarHeight = 18;
constexpr int kBarTop = 34;  // below the panel's top
constexpr int kBarPitch = 28;

std::string F2(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.2f", v);
  return b;
}

void Text(cv::Mat& img, const std::string& s, cv::Point at, const cv::Scalar& colour, double scale = 0.55) {
  cv::putText(img, s, at, cv::FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv::LINE_AA);
}

// The eye image scaled into its column, with the detection drawn on it.
void DrawEye(cv::Mat& canvas, int eye, const cv::Mat& image, const calib::TargetDetection& d) {
  cv::Mat roi = canvas(cv::Rect(eye * kLiveEyeWidth, 0, kLiveEyeWidth, kLiveEyeHeight));
  double sx = 1, sy = 1;
  if (image.empty()) {
    roi.setTo(cv::Scalar(90, 90, 90));
  } else {
    cv::Mat bgr;
    if (image.channels() == 1)
      cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
    else
      bgr = image;
    cv::resize(bgr, roi, roi.size(), 0, 0, cv::INTER_AREA);
    sx = double(kLiveEyeWidth) / image.cols;
    sy = double(kLiveEyeHeight) / image.rows;
  }
  const char* name = models::kEyeNames[eye];
  Text(roi, std::string(name) + " eye", {10, 24}, cv::Scalar(255, 255, 255), 0.7);
  if (!d.found) {
    Text(roi,
         "no board" + (d.message.empty() ? std::string() : ": " + d.message.substr(0, 48)),
         {10, 52},
         cv::Scalar(40, 40, 255),
         0.6);
    return;
  }
  // Corners joined in id order (as cv::drawChessboardCorners), hue running along the ids.
  std::vector<std::pair<int, cv::Point2d>> pts;
  for (size_t i = 0; i < d.pixels.size() && i < d.corner_ids.size(); ++i)
    pts.push_back({d.corner_ids[i], cv::Point2d(d.pixels[i].x() * sx, d.pixels[i].y() * sy)});
  std::sort(pts.begin(), pts.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (size_t i = 0; i < pts.size(); ++i) {
    const double t = pts.size() > 1 ? double(i) / (pts.size() - 1) : 0;
    const cv::Scalar c(255 * (1 - t), 120 + 100 * std::sin(t * M_PI), 255 * t);
    if (i > 0) cv::line(roi, pts[i - 1].second, pts[i].second, c, 1, cv::LINE_AA);
    cv::circle(roi, pts[i].second, 4, c, 2, cv::LINE_AA);
  }
  Text(roi, std::to_string(pts.size()) + " corners", {10, 52}, cv::Scalar(60, 220, 60), 0.6);
}

void DrawPanel(cv::Mat& canvas, int eye, const Coverage& c) {
  const int x0 = eye * kLiveEyeWidth;
  const int y0 = kLiveEyeHeight;
  Text(canvas,
       std::string(models::kEyeNames[eye]) + " eye: " + std::to_string(c.num_views) + " views" +
           (c.Good() ? "  - coverage GOOD" : ""),
       {x0 + 10, y0 + 22},
       c.Good() ? cv::Scalar(60, 220, 60) : cv::Scalar(255, 255, 255),
       0.6);
  for (int k = 0; k < 4; ++k) {
    const cv::Rect bar = LiveBarRect(eye, k);
    Text(canvas, kParamNames[k], {x0 + 12, bar.y + bar.height - 3}, cv::Scalar(255, 255, 255));
    cv::rectangle(canvas, bar, kLiveBarEmpty, cv::FILLED);
    const double p = std::clamp(c.progress[k], 0.0, 1.0);
    const int w = int(std::lround(p * bar.width));
    if (w > 0)
      cv::rectangle(canvas, cv::Rect(bar.x, bar.y, w, bar.height), p >= 1 ? kLiveBarDone : kLiveBarPartial, cv::FILLED);
    Text(canvas,
         c.num_views ? F2(c.min[k]) + ".." + F2(c.max[k]) : "-",
         {bar.x + bar.width + 10, bar.y + bar.height - 3},
         cv::Scalar(220, 220, 220),
         0.5);
  }
  int y = y0 + kBarTop + 4 * kBarPitch + 12;
  for (const std::string& line : MissingViews(c)) {
    if (y > canvas.rows - 6) break;
    Text(canvas, "missing " + line, {x0 + 12, y}, cv::Scalar(80, 180, 255), 0.45);
    y += 18;
  }
}

}  // namespace

std::vector<std::string> MissingViews(const Coverage& c) {
  if (c.num_views == 0) return {"no view of the board yet"};
  std::vector<std::string> out;
  // X and Y: the side that is not yet reached (ROS needs a spread of 0.7 of the normalised
  // board position; a side counts as reached within 0.15 of the image edge).
  if (c.progress[0] < 1) {
    std::string s;
    if (c.min[0] > 0.15) s += "further to the left";
    if (c.max[0] < 0.85) s += std::string(s.empty() ? "" : " and ") + "further to the right";
    if (s.empty()) s = "more spread left-right";
    out.push_back("X: views " + s);
  }
  if (c.progress[1] < 1) {
    std::string s;
    if (c.min[1] > 0.15) s += "higher (top of the image)";
    if (c.max[1] < 0.85) s += std::string(s.empty() ? "" : " and ") + "lower (bottom of the image)";
    if (s.empty()) s = "more spread up-down";
    out.push_back("Y: views " + s);
  }
  if (c.progress[2] < 1)
    out.push_back(std::string("Size: ") +
                  (c.max[2] < 0.55 ? "the board closer (filling more of the image)" : "the board further away"));
  if (c.progress[3] < 1) out.push_back("Skew: the board tilted more (about 30 deg)");
  return out;
}

cv::Rect LiveBarRect(int eye, int k) {
  return cv::Rect(eye * kLiveEyeWidth + kBarLeft, kLiveEyeHeight + kBarTop + k * kBarPitch, kBarWidth, kBarHeight);
}

cv::Mat RenderLiveFrame(const LiveDetection& frame, const LiveState& state) {
  cv::Mat canvas(kLiveEyeHeight + kLivePanelHeight, 2 * kLiveEyeWidth, CV_8UC3, cv::Scalar(30, 30, 30));
  DrawEye(canvas, models::kLeftEye, frame.left, frame.detection[models::kLeftEye]);
  DrawEye(canvas, models::kRightEye, frame.right, frame.detection[models::kRightEye]);
  for (int e = 0; e < 2; ++e) DrawPanel(canvas, e, state.coverage[e]);
  cv::line(canvas, {kLiveEyeWidth, 0}, {kLiveEyeWidth, canvas.rows}, cv::Scalar(200, 200, 200), 1);
  if (!state.status.empty())
    Text(canvas, state.status, {kLiveEyeWidth - 300, kLiveEyeHeight - 10}, cv::Scalar(255, 255, 255), 0.5);
  return canvas;
}

bool LiveFeedbackOptions::Check(std::string* why) const {
  if (bind_address.empty()) {
    *why = "live feedback: bind address is empty";
    return false;
  }
  if (port < 0 || port > 65535) {
    *why = "live feedback: port " + std::to_string(port) + " is outside 0..65535";
    return false;
  }
  if (jpeg_quality < 1 || jpeg_quality > 100) {
    *why = "live feedback: jpeg_quality " + std::to_string(jpeg_quality) + " is outside 1..100";
    return false;
  }
  return true;
}

LiveFeedback::LiveFeedback(const LiveFeedbackOptions& options) : options_(options) {
  std::string why;
  if (!options_.Check(&why)) throw std::invalid_argument(why);
  robot::MjpegServerOptions so;
  so.bind_address = options_.bind_address;
  so.port = options_.port;
  // The newest frame is sent again at 5 fps, so a viewer that connects between two detections
  // sees the current state at once.
  so.fps = 5;
  server_ = std::make_unique<robot::MjpegServer>(
      so,
      [this]() -> std::optional<std::vector<uint8_t>> {
        std::lock_guard<std::mutex> lock(mutex_);
        if (last_jpeg_.empty()) return std::nullopt;
        return last_jpeg_;
      },
      [this](const robot::HttpRequest& r) -> std::optional<robot::HttpResponse> {
        if (r.method != "GET" || r.path != "/frame.jpg") return std::nullopt;
        std::lock_guard<std::mutex> lock(mutex_);
        if (last_jpeg_.empty()) return robot::HttpResponse{503, "text/plain", "no frame yet\n", {}};
        return robot::HttpResponse{200, "image/jpeg", std::string(last_jpeg_.begin(), last_jpeg_.end()), {}};
      });
  server_->Start();
}

LiveFeedback::~LiveFeedback() { server_->Stop(); }

int LiveFeedback::Port() const { return server_->Port(); }

std::string LiveFeedback::Url() const {
  return "http://" + options_.bind_address + ":" + std::to_string(Port()) + "/stream/video.mjpeg";
}

void LiveFeedback::Update(const LiveDetection& frame) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (int e = 0; e < 2; ++e)
      if (frame.has_view[e]) views_[e].push_back(frame.view[e]);
    ++num_frames_;
    LiveState state;
    for (int e = 0; e < 2; ++e) state.coverage[e] = ComputeCoverage(views_[e]);
    state.status = (frame.step_name.empty() ? std::string() : "step " + frame.step_name + ", ") + "frame " +
                   std::to_string(num_frames_);
    last_ = RenderLiveFrame(frame, state);
    cv::imencode(".jpg", last_, last_jpeg_, {cv::IMWRITE_JPEG_QUALITY, options_.jpeg_quality});
  }
}

cv::Mat LiveFeedback::LastFrame() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return last_.clone();
}

std::array<Coverage, 2> LiveFeedback::CurrentCoverage() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return {ComputeCoverage(views_[0]), ComputeCoverage(views_[1])};
}

}  // namespace owlcal::protocols
