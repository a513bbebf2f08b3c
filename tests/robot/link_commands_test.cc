// The functions behind `owlcal move`, `centre` and `grab`, against the loopback servers.
#include "robot/link_commands.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <mutex>

#include <opencv2/imgcodecs.hpp>

#include "robot/mjpeg_client.h"
#include "robot/mjpeg_server.h"
#include "robot/servo_server.h"
#include "robot/socket_util.h"

namespace owlcal::robot {
namespace {

class LinkCommandsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    server_ = std::make_unique<ServoServer>(ServoServerOptions{}, nullptr, [this](const std::string& r) {
      std::lock_guard<std::mutex> lock(mutex_);
      raw_.push_back(r);
    });
    server_->Start();
    robot_ = "127.0.0.1:" + std::to_string(server_->Port());
  }
  std::vector<std::string> Raw() {
    std::lock_guard<std::mutex> lock(mutex_);
    return raw_;
  }
  std::mutex mutex_;
  std::vector<std::string> raw_;
  std::unique_ptr<ServoServer> server_;
  std::string robot_;
};

TEST_F(LinkCommandsTest, MoveSendsClampsAndReports) {
  const MoveReport r = SendOneCommand(robot_, models::DefaultRobotConfig(), {1500, 2500, 1545, 1580, 1000});
  EXPECT_EQ(Raw().at(0), "1500 2000 1545 1580 1100");
  EXPECT_TRUE(r.reply.clamped);
  EXPECT_EQ(r.reply.text, "ok");
  const std::string text = r.Text();
  EXPECT_NE(text.find("sent:    1500 2000 1545 1580 1100"), std::string::npos) << text;
  EXPECT_NE(text.find("Ry = 2500 us clamped to 2000 (max_us)"), std::string::npos) << text;
  EXPECT_NE(text.find("Neck = 1000 us clamped to 1100 (min_us)"), std::string::npos) << text;
  EXPECT_NE(text.find("reply:   \"ok\""), std::string::npos) << text;
}

TEST_F(LinkCommandsTest, CentreUsesTheRobotFile) {
  models::RobotConfig robot = RobotConfigOrDefault("");
  EXPECT_EQ(robot.Centre(), models::DefaultRobotConfig().Centre());
  robot.servos[models::kNeck].centre_us = 1510;
  const MoveReport r = SendOneCommand(robot_, robot, robot.Centre());
  EXPECT_FALSE(r.reply.clamped);
  EXPECT_EQ(Raw().at(0), "1545 1530 1545 1580 1510");
  EXPECT_EQ(r.Text().find("clamped"), std::string::npos);
}

TEST_F(LinkCommandsTest, UnreachableRobotThrowsNamingIt) {
  int port = 0;
  { Socket s = Listen("127.0.0.1", 0, &port); }
  try {
    SendOneCommand("127.0.0.1:" + std::to_string(port),
                   models::DefaultRobotConfig(),
                   {1545, 1530, 1545, 1580, 1530},
                   std::chrono::milliseconds(200));
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("127.0.0.1:" + std::to_string(port)), std::string::npos) << e.what();
  }
  EXPECT_THROW(SendOneCommand("127.0.0.1:99999", models::DefaultRobotConfig(), {1545, 1530, 1545, 1580, 1530}),
               std::invalid_argument);
}

// Regression: --timeout-ms bounds the whole command (connect, reply and any resend together).
TEST(SendOneCommand, TimeoutIsHonouredAsStated) {
  int port = 0;
  Socket silent = Listen("127.0.0.1", 0, &port);  // connects, never answers
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_THROW(SendOneCommand("127.0.0.1:" + std::to_string(port),
                              models::DefaultRobotConfig(),
                              {1545, 1530, 1545, 1580, 1530},
                              std::chrono::milliseconds(400)),
               std::runtime_error);
  const auto took = std::chrono::steady_clock::now() - t0;
  EXPECT_GE(took, std::chrono::milliseconds(350));
  EXPECT_LT(took, std::chrono::milliseconds(650));  // was 400 + 100 + 400
}

TEST(GrabOneFrame, WritesLeftRightAndTheRawFrame) {
  cv::Mat sbs(480, 1280, CV_8UC3, cv::Scalar(10, 10, 10));
  sbs(cv::Rect(640, 0, 640, 480)).setTo(cv::Scalar(240, 240, 240));  // right half bright
  std::vector<uint8_t> jpeg;
  cv::imencode(".jpg", sbs, jpeg);
  MjpegServer video({}, [&] { return std::optional(jpeg); });
  video.Start();
  const auto dir = std::filesystem::temp_directory_path() / "owlcal_grab_test";
  std::filesystem::remove_all(dir);
  models::RobotConfig unmirrored = models::DefaultRobotConfig();
  unmirrored.mirror_stream = false;  // the default robot streams mirrored like a real Owl
  const GrabReport r = GrabOneFrame("127.0.0.1", video.Port(), unmirrored, dir.string());
  EXPECT_EQ(r.width, 1280);
  EXPECT_EQ(r.height, 480);
  const cv::Mat left = cv::imread(r.left_png), right = cv::imread(r.right_png), frame = cv::imread(r.frame_jpg);
  ASSERT_EQ(left.size(), cv::Size(640, 480));
  ASSERT_EQ(right.size(), cv::Size(640, 480));
  ASSERT_EQ(frame.size(), cv::Size(1280, 480));
  EXPECT_LT(cv::mean(left)[0], 30);
  EXPECT_GT(cv::mean(right)[0], 220);
  EXPECT_EQ(std::filesystem::file_size(r.frame_jpg), jpeg.size());
  std::filesystem::remove_all(dir);
}

// Regression: a 631-byte JPEG declaring 30000x30000 made `grab` take 5.3 GB and write 30000x15000
// PNGs, past its own timeout. The SOF size is checked against the robot file before decoding.
TEST(GrabOneFrame, FrameLargerThanTheRobotFileIsNeverDecoded) {
  cv::Mat small(8, 16, CV_8UC3, cv::Scalar(10, 10, 10));
  std::vector<uint8_t> jpeg;
  cv::imencode(".jpg", small, jpeg);
  const std::optional<JpegSize> size = JpegDeclaredSize(jpeg.data(), jpeg.size());
  ASSERT_TRUE(size);
  EXPECT_EQ(size->width, 16);
  EXPECT_EQ(size->height, 8);
  // Patch the SOF to declare 30000x30000.
  size_t sof = 0;
  for (size_t i = 2; i + 8 < jpeg.size(); ++i)
    if (jpeg[i] == 0xFF && jpeg[i + 1] == 0xC0) {
      sof = i;
      break;
    }
  ASSERT_GT(sof, 0u);
  jpeg[sof + 5] = 30000 >> 8, jpeg[sof + 6] = 30000 & 0xFF, jpeg[sof + 7] = 30000 >> 8, jpeg[sof + 8] = 30000 & 0xFF;
  EXPECT_EQ(JpegDeclaredSize(jpeg.data(), jpeg.size())->width, 30000);
  MjpegServer video({}, [&] { return std::optional(jpeg); });
  video.Start();
  const auto t0 = std::chrono::steady_clock::now();
  try {
    GrabOneFrame("127.0.0.1",
                 video.Port(),
                 models::DefaultRobotConfig(),
                 "/tmp/owlcal_never_big",
                 std::chrono::milliseconds(500));
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("declares 30000x30000, the robot file says 1280x480"), std::string::npos)
        << e.what();
  }
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(1500));
  EXPECT_FALSE(std::filesystem::exists("/tmp/owlcal_never_big"));
}

TEST(GrabOneFrame, NoStreamThrowsNamingTheUrl) {
  int port = 0;
  { Socket s = Listen("127.0.0.1", 0, &port); }
  try {
    GrabOneFrame("127.0.0.1", port, models::DefaultRobotConfig(), "/tmp/owlcal_never", std::chrono::milliseconds(300));
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("http://127.0.0.1:" + std::to_string(port) + "/stream/video.mjpeg"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace owlcal::robot
