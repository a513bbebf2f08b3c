// Live capture feedback: the runner hands every detected frame of a `detect: true` step to the
// live feedback, which serves a frame with the overlay, the coverage bars and the missing views
// as MJPEG on 127.0.0.1; a client fetches one over loopback, decodes it and finds the bars.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "protocols/live_feedback.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "sim/virtual_owl.h"

namespace owlcal::protocols {
namespace {
namespace fs = std::filesystem;

// GETs `path` from 127.0.0.1:port and returns everything received until `enough` says the
// bytes suffice or the server closes (5 s at most).
std::string HttpGet(int port, const std::string& path, const std::function<bool(const std::string&)>& enough) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  EXPECT_GE(fd, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(uint16_t(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    ADD_FAILURE() << "cannot connect to 127.0.0.1:" << port;
    return "";
  }
  const std::string req = "GET " + path + " HTTP/1.0\r\nHost: 127.0.0.1\r\n\r\n";
  EXPECT_EQ(::send(fd, req.data(), req.size(), 0), ssize_t(req.size()));
  std::string got;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (std::chrono::steady_clock::now() < deadline && !enough(got)) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 100) <= 0) continue;
    char buf[65536];
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    got.append(buf, size_t(n));
  }
  ::close(fd);
  return got;
}

// The first JPEG of an MJPEG stream response (its Content-Length part), decoded.
cv::Mat FirstStreamFrame(int port) {
  auto part = [](const std::string& s, std::string* jpeg) {
    const size_t cl = s.find("Content-Length: ");
    if (cl == std::string::npos) return false;
    const size_t eol = s.find("\r\n", cl);
    if (eol == std::string::npos) return false;
    const size_t n = std::stoul(s.substr(cl + 16, eol - cl - 16));
    const size_t body = s.find("\r\n\r\n", cl);
    if (body == std::string::npos || s.size() < body + 4 + n) return false;
    if (jpeg) *jpeg = s.substr(body + 4, n);
    return true;
  };
  const std::string got = HttpGet(port, "/stream/video.mjpeg", [&](const std::string& s) { return part(s, nullptr); });
  EXPECT_NE(got.find("multipart/x-mixed-replace"), std::string::npos);
  std::string jpeg;
  if (!part(got, &jpeg)) return {};
  return cv::imdecode(std::vector<uint8_t>(jpeg.begin(), jpeg.end()), cv::IMREAD_COLOR);
}

// Fraction of a bar's pixels within 40 grey levels (per channel) of colour c.
double ColourFraction(const cv::Mat& img, const cv::Rect& r, const cv::Scalar& c) {
  int n = 0;
  for (int y = r.y + 3; y < r.y + r.height - 3; ++y)
    for (int x = r.x; x < r.x + r.width; ++x) {
      const cv::Vec3b p = img.at<cv::Vec3b>(y, x);
      n += std::abs(p[0] - c[0]) < 40 && std::abs(p[1] - c[1]) < 40 && std::abs(p[2] - c[2]) < 40;
    }
  return double(n) / ((r.height - 6) * r.width);
}

TEST(LiveFeedback, MissingViewsNamesTheSidesNotYetCovered) {
  EXPECT_EQ(MissingViews(Coverage{}), std::vector<std::string>{"no view of the board yet"});
  std::vector<ViewParams> v = {{0.40, 0.05, 0.20, 0.0}, {0.60, 0.95, 0.25, 0.1}};
  const Coverage c = ComputeCoverage(v);
  const std::vector<std::string> m = MissingViews(c);
  ASSERT_EQ(m.size(), 3u);  // X, Size and Skew; Y spans 0.05..0.95
  EXPECT_NE(m[0].find("further to the left and further to the right"), std::string::npos) << m[0];
  EXPECT_NE(m[1].find("Size: the board closer"), std::string::npos) << m[1];
  EXPECT_NE(m[2].find("Skew"), std::string::npos) << m[2];
  const Coverage good = ComputeCoverage({{0.0, 0.0, 0.1, 0.0}, {1.0, 1.0, 0.6, 0.6}});
  EXPECT_TRUE(good.Good());
  EXPECT_TRUE(MissingViews(good).empty());
}

TEST(LiveFeedback, RunnerFeedsTheServedFrameWithOverlayAndCoverageBars) {
  const Protocol p = ParseProtocolYaml(R"(
name: live
target: chessboard
targets:
  chessboard: {target_type: chessboard, cols: 9, rows: 6, square_size_m: 0.026}
steps:
  - place-target: {target: chessboard, distance_m: 0.55}
  - grid: {name: facing, eyes: both, pan_us: [-80, 0, 80], tilt_us: [-70, 70],
           frames: 1, settle: {mode: time, time_ms: 250}, detect: true}
)",
                                       "live.yaml");
  std::unique_ptr<robot::RobotInterface> owl = std::make_unique<sim::VirtualOwl>(sim::VirtualOwlOptions{});
  LiveFeedback live(LiveFeedbackOptions{});
  ASSERT_GT(live.Port(), 0);
  EXPECT_EQ(live.Url().rfind("http://127.0.0.1:", 0), 0u);
  int updates = 0, found_left = 0;
  bool last_found[2] = {false, false};
  RunOptions o;
  o.out_dir = (fs::temp_directory_path() / ("owlcal_live_" + std::to_string(::getpid()))).string();
  fs::remove_all(o.out_dir);
  o.on_detection = [&](const LiveDetection& d) {
    ++updates;
    found_left += d.detection[0].found;
    for (int e = 0; e < 2; ++e) last_found[e] = d.detection[e].found;
    live.Update(d);
  };
  const RunSummary s = RunProtocols({p}, *owl, o);
  ASSERT_EQ(s.status, "complete") << s.message;
  EXPECT_EQ(updates, 6);
  EXPECT_GE(found_left, 4);
  const std::array<Coverage, 2> cov = live.CurrentCoverage();
  EXPECT_EQ(cov[0].num_views, found_left);
  EXPECT_GT(cov[0].progress[0], 0.3);  // the board moved across the image
  EXPECT_LT(cov[0].progress[2], 1);    // one distance: size is missing (a partial bar)

  // Over loopback: the stream's first frame decodes at the layout's size and shows the bars.
  const cv::Mat frame = FirstStreamFrame(live.Port());
  ASSERT_FALSE(frame.empty());
  ASSERT_EQ(frame.cols, 2 * kLiveEyeWidth);
  ASSERT_EQ(frame.rows, kLiveEyeHeight + kLivePanelHeight);
  for (int e = 0; e < 2; ++e)
    for (int k = 0; k < 4; ++k) {
      const cv::Rect bar = LiveBarRect(e, k);
      const double p = std::min(1.0, cov[e].progress[k]);
      const double filled = ColourFraction(frame, bar, p >= 1 ? kLiveBarDone : kLiveBarPartial);
      const double empty = ColourFraction(frame, bar, kLiveBarEmpty);
      EXPECT_NEAR(filled, p, 0.05) << "eye " << e << " bar " << k;
      EXPECT_NEAR(empty, 1 - p, 0.05) << "eye " << e << " bar " << k;
    }
  // The overlay: the detected corners are drawn on the left eye (saturated colours the grey
  // rendered board does not have).
  const cv::Mat last = live.LastFrame();
  ASSERT_TRUE(last_found[0] || last_found[1]);
  const int x0 = last_found[0] ? 0 : kLiveEyeWidth;
  int saturated = 0;
  for (int y = 60; y < kLiveEyeHeight; ++y)  // below the title lines
    for (int x = x0; x < x0 + kLiveEyeWidth; ++x) {
      const cv::Vec3b q = last.at<cv::Vec3b>(y, x);
      saturated += std::max({q[0], q[1], q[2]}) - std::min({q[0], q[1], q[2]}) > 120;
    }
  EXPECT_GT(saturated, 200);
  // One frame as a JPEG too.
  const std::string one = HttpGet(live.Port(), "/frame.jpg", [](const std::string&) { return false; });
  EXPECT_NE(one.find("image/jpeg"), std::string::npos);
  fs::remove_all(o.out_dir);
}

}  // namespace
}  // namespace owlcal::protocols
