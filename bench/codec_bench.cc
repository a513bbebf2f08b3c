// Prints the robot link's figures: codec + guard cost, loopback servo round trip, and MJPEG
// client throughput on the real stereo JPEGs. Figures only; nothing is asserted.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <numeric>
#include <random>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "owlcal_version.h"
#include "robot/limits_guard.h"
#include "robot/mjpeg_client.h"
#include "robot/mjpeg_server.h"
#include "robot/packet_codec.h"
#include "robot/servo_client.h"
#include "robot/servo_server.h"

using namespace owlcal;
using Clock = std::chrono::steady_clock;

static double Ms(Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

int main() {
  // 1. Codec + guard.
  {
    robot::LimitsGuard guard(models::DefaultRobotConfig());
    std::mt19937 rng(1);
    std::uniform_int_distribution<int> v(1000, 2200);
    const int n = 1000000;
    int64_t checksum = 0;
    const auto t0 = Clock::now();
    for (int i = 0; i < n; ++i) {
      models::PwmVector p;
      for (int& x : p) x = v(rng);
      const robot::ClampResult c = guard.Clamp(p);
      const std::string bytes = robot::EncodePacket(c.pwm_us);
      const robot::DecodeResult d = robot::DecodePacket(bytes);
      checksum += (*d.pwm_us)[0];
    }
    std::printf("codec: clamp + encode + decode: %.1f ns per packet (checksum %lld)\n",
                Ms(Clock::now() - t0) * 1e6 / n,
                static_cast<long long>(checksum));
  }
  // 2. Servo round trip on loopback (client -> server -> "ok").
  {
    robot::ServoServer server({}, nullptr);
    server.Start();
    robot::ServoClient client({.host = "127.0.0.1", .port = server.Port()});
    std::vector<double> ms;
    for (int i = 0; i < 2000; ++i) {
      const auto t0 = Clock::now();
      const robot::ServoClientReply r = client.Send({1545 + i % 50, 1530, 1545, 1580, 1530});
      if (!r.ok) {
        std::printf("servo round trip: failed: %s\n", r.error.c_str());
        return 1;
      }
      ms.push_back(Ms(Clock::now() - t0));
    }
    std::sort(ms.begin(), ms.end());
    std::printf("servo round trip (loopback, 2000 packets): mean %.3f ms, median %.3f ms, p99 %.3f ms\n",
                std::accumulate(ms.begin(), ms.end(), 0.0) / ms.size(),
                ms[ms.size() / 2],
                ms[ms.size() * 99 / 100]);
  }
  // 3. MJPEG client throughput with decode + split, on the OpenCV stereo pairs side by side.
  {
    const std::filesystem::path dir = std::filesystem::path(OWLCAL_DATA_DIR) / "opencv-stereo-chessboard";
    std::vector<std::vector<uint8_t>> jpegs;
    for (int i = 1; i <= 14; ++i) {
      if (i == 10) continue;  // the set has no pair 10
      char left[32], right[32];
      std::snprintf(left, sizeof(left), "left%02d.jpg", i);
      std::snprintf(right, sizeof(right), "right%02d.jpg", i);
      const cv::Mat l = cv::imread((dir / left).string());
      const cv::Mat r = cv::imread((dir / right).string());
      if (l.empty() || r.empty()) continue;
      cv::Mat sbs;
      cv::hconcat(l, r, sbs);
      std::vector<uint8_t> j;
      cv::imencode(".jpg", sbs, j, {cv::IMWRITE_JPEG_QUALITY, 85});
      jpegs.push_back(std::move(j));
    }
    if (jpegs.empty()) {
      std::printf("mjpeg: no images under %s\n", dir.c_str());
      return 0;
    }
    size_t next = 0;
    robot::MjpegServerOptions so;
    so.fps = 1000;
    robot::MjpegServer server(so, [&] { return std::optional(jpegs[next++ % jpegs.size()]); });
    server.Start();
    for (bool decode : {false, true}) {
      robot::MjpegClientOptions co;
      co.port = server.Port();
      co.decode = decode;
      robot::MjpegClient client(co);
      client.Next(std::chrono::seconds(5));
      const int n = 300;
      const auto t0 = Clock::now();
      int got = 0;
      for (int i = 0; i < n; ++i) got += client.Next(std::chrono::seconds(5)).has_value();
      const double s = Ms(Clock::now() - t0) / 1000;
      std::printf("mjpeg client (%s, 1280x480 q85, ~%zu kB): %d frames in %.2f s = %.0f frames/s\n",
                  decode ? "decode + split" : "raw JPEG only",
                  jpegs[0].size() / 1024,
                  got,
                  s,
                  got / s);
    }
  }
  return 0;
}
