#pragma once
// Live capture feedback: while a protocol captures board views (robot-driven,
// or a person placing the board at the runner's prompt), the person sees what the capture has
// so far, as ROS camera_calibration shows it:
//   - both eye images with the detection overlay (every detected corner, joined in id order;
//     "no board" in red when an eye found none);
//   - per eye, the coverage bars X, Y, Size and Skew (protocols/coverage.h: progress 0..1,
//     green when complete, yellow while not) with the min..max covered so far;
//   - which views are still missing, in words ("X: views further to the right"), per eye.
// The rendered frame is served as MJPEG on a local port (robot::MjpegServer, bound to
// 127.0.0.1 unless told otherwise): open http://127.0.0.1:PORT/stream/video.mjpeg in a browser
// or with cv::VideoCapture; the newest frame is repeated at 5 fps. GET /frame.jpg answers it as
// one JPEG.
//
// Frame layout (LiveFrameLayout): the two eye images side by side (left eye first, each
// scaled to kLiveEyeWidth x kLiveEyeHeight), under them a panel of kLivePanelHeight px per
// eye column: a title line, the four bars, then the missing-view lines.
//
// Usage:
//   LiveFeedbackOptions lo; lo.port = 8090;
//   LiveFeedback live(lo);
//   RunOptions ro; ro.on_detection = [&](const LiveDetection& d) { live.Update(d); };
#include <array>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "calib/detector.h"
#include "protocols/coverage.h"
#include "robot/mjpeg_server.h"

namespace owlcal::protocols {

inline constexpr int kLiveEyeWidth = 640;
inline constexpr int kLiveEyeHeight = 480;
inline constexpr int kLivePanelHeight = 230;

// One frame the runner detected the protocol's target in (or tried to), per eye.
struct LiveDetection {
  cv::Mat left, right;                              // 8-bit BGR eye images
  std::array<calib::TargetDetection, 2> detection;  // per eye (models::kLeftEye, kRightEye)
  std::array<bool, 2> has_view{};                   // per eye: view params computed
  std::array<ViewParams, 2> view{};
  std::string step_name;
};

// The state the frame shows.
struct LiveState {
  std::array<Coverage, 2> coverage;  // per eye
  std::string status;                // one line (step, views so far)
};

// What is still missing for `c` to be good, one line per parameter that is not complete
// ("X: views further to the left"; the bars show the ranges covered); {"no view of the board yet"} with no
// views; empty when the coverage is good.
std::vector<std::string> MissingViews(const Coverage& c);

// Where the bar of parameter k (0 X, 1 Y, 2 Size, 3 Skew) of eye e is drawn in the frame (the
// full bar; the filled part is the left progress fraction of it).
cv::Rect LiveBarRect(int eye, int k);
// BGR colours of a complete bar's fill, an incomplete bar's fill and the empty part.
inline const cv::Scalar kLiveBarDone(60, 200, 60), kLiveBarPartial(40, 200, 230), kLiveBarEmpty(70, 70, 70);

// Renders the feedback frame (8-bit BGR, 2 * kLiveEyeWidth x kLiveEyeHeight + kLivePanelHeight).
// Empty eye images are drawn grey.
cv::Mat RenderLiveFrame(const LiveDetection& frame, const LiveState& state);

struct LiveFeedbackOptions {
  std::string bind_address = "127.0.0.1";
  int port = 0;  // 0 = any free port (Port() tells)
  int jpeg_quality = 85;
  bool Check(std::string* why) const;
};

// Accumulates the coverage of the detections it is given and serves the rendered frame.
class LiveFeedback {
 public:
  // Starts serving; throws std::invalid_argument on bad options and std::runtime_error naming
  // address:port when it cannot bind.
  explicit LiveFeedback(const LiveFeedbackOptions& options);
  ~LiveFeedback();
  int Port() const;
  std::string Url() const;  // http://ADDRESS:PORT/stream/video.mjpeg

  // Adds the frame's views to the coverage and renders the frame the server sends. Thread-safe.
  void Update(const LiveDetection& frame);
  // The newest rendered frame (empty before the first Update) and the coverage so far.
  cv::Mat LastFrame() const;
  std::array<Coverage, 2> CurrentCoverage() const;

 private:
  LiveFeedbackOptions options_;
  std::unique_ptr<robot::MjpegServer> server_;
  mutable std::mutex mutex_;
  std::array<std::vector<ViewParams>, 2> views_;
  int num_frames_ = 0;
  cv::Mat last_;
  std::vector<uint8_t> last_jpeg_;
};

}  // namespace owlcal::protocols
