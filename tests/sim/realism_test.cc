// The virtual Owl's roughness: a held board's motion, a bowed board, the rolling shutter, the
// prior of real Owls and the students' kind of capture. Corner truth is computed with
// cv::projectPoints (not the renderer's own code).
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/detector.h"
#include "sim/handheld_capture.h"
#include "sim/robot_prior.h"
#include "sim/virtual_owl.h"

namespace owlcal::sim {
namespace {

std::vector<cv::Point2f> Project(const models::CameraIntrinsics& k,
                                 const Eigen::Matrix4d& cam_from_target,
                                 const std::vector<Eigen::Vector3d>& points) {
  cv::Mat r(3, 3, CV_64F), rvec, tvec(3, 1, CV_64F);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r.at<double>(i, j) = cam_from_target(i, j);
    tvec.at<double>(i) = cam_from_target(i, 3);
  }
  cv::Rodrigues(r, rvec);
  const auto& p = k.params;
  const cv::Matx33d km(p[0], 0, p[2], 0, p[1], p[3], 0, 0, 1);
  std::vector<double> dist(p.begin() + 4, p.end());
  std::vector<cv::Point3f> obj;
  for (const auto& x : points) obj.emplace_back(float(x.x()), float(x.y()), float(x.z()));
  std::vector<cv::Point2f> img;
  cv::projectPoints(obj, rvec, tvec, km, dist, img);
  return img;
}

double Rms(const std::vector<cv::Point2f>& a, const std::vector<Eigen::Vector2d>& b) {
  double s = 0;
  for (size_t i = 0; i < a.size(); ++i) s += std::pow(a[i].x - b[i].x(), 2) + std::pow(a[i].y - b[i].y(), 2);
  return std::sqrt(s / a.size());
}

// A noise-free owl with sharp-ish edges, only the chessboard visible.
VirtualOwlOptions Clean(const SceneDescription& scene) {
  VirtualOwlOptions o;
  o.seed = 5;
  o.noise_sigma = 0;
  o.scene = scene;
  return o;
}

TEST(TargetMotion, StillIsIdentityAndHeldMovesAtTheRmsSpeed) {
  EXPECT_TRUE(TargetMotion().Offset(123456789).isApprox(Eigen::Isometry3d::Identity()));
  TargetMotion m;
  m.speed_m_s = 0.05;
  m.angular_speed_deg_s = 4;
  m.seed = 9;
  double v2 = 0, w2 = 0, max_excursion = 0;
  const int n = 20000;
  const int64_t dt = 1'000'000;  // 1 ms
  for (int i = 0; i < n; ++i) {
    const Eigen::Isometry3d a = m.Offset(i * dt), b = m.Offset((i + 1) * dt);
    v2 += (b.translation() - a.translation()).squaredNorm() / 1e-6;
    w2 += std::pow(Eigen::AngleAxisd(b.linear() * a.linear().transpose()).angle() * 180 / M_PI, 2) / 1e-6;
    max_excursion = std::max(max_excursion, a.translation().norm());
  }
  EXPECT_NEAR(std::sqrt(v2 / n), 0.05, 0.01);
  EXPECT_NEAR(std::sqrt(w2 / n), 4.0, 0.8);
  EXPECT_LT(max_excursion, 0.05);  // a held board sways by centimetres, not more
  TargetMotion other = m;
  other.seed = 10;
  EXPECT_FALSE(m.Offset(5'000'000'000).isApprox(other.Offset(5'000'000'000)));
  EXPECT_TRUE(m.Offset(5'000'000'000).isApprox(m.Offset(5'000'000'000)));
}

TEST(BoardWarp, RenderedCornersLieOnTheBowedBoard) {
  SceneDescription scene = DefaultScene();
  SceneTarget* board = scene.Find("chessboard");
  board->warp_m = Eigen::Vector2d(2e-3, 0.5e-3);
  board->base_from_target = FacingPose(board->definition, {0.02, 0.01, 0.45}, 30, -10, 5);
  VirtualOwl owl(Clean(scene));
  owl.SetTargetVisible("aprilgrid", false);
  owl.SetTargetVisible("fixation", false);
  const auto frame = owl.GrabFrame(0, 1'000'000'000);
  ASSERT_TRUE(frame.has_value());
  const FrameTruth ft = owl.TruthForFrame(frame->seq);
  const SceneDescription state = owl.SceneState();
  const SceneTarget* t = state.Find("chessboard");
  std::vector<Eigen::Vector3d> flat, bowed;
  for (const auto& [id, p] : t->definition.Corners()) {
    flat.push_back(p);
    bowed.push_back(t->WarpedPoint(p));
  }
  // The bow: the middle corner 2 + 0.5 mm towards the camera, the corner grid's corners not at all.
  EXPECT_NEAR(t->WarpedPoint(Eigen::Vector3d(4 * 0.026, 2.5 * 0.026, 0)).z(), -2.5e-3, 1e-9);
  EXPECT_NEAR(t->WarpedPoint(Eigen::Vector3d(0, 0, 0)).z(), 0, 1e-12);
  for (int e = 0; e < 2; ++e) {
    const cv::Mat img = e == 0 ? frame->left : frame->right;
    const calib::TargetDetection d = calib::DetectTarget(img, t->definition, {});
    ASSERT_TRUE(d.found) << d.message;
    const Eigen::Matrix4d cam_from_target = ft.cam_from_base[e].Matrix() * t->base_from_target.matrix();
    const auto k = owl.Truth().intrinsics[e];
    // Detection order is the corner id order (row * cols + col).
    std::vector<Eigen::Vector2d> found(d.pixels.size());
    for (size_t i = 0; i < d.pixels.size(); ++i) found[d.corner_ids[i]] = d.pixels[i];
    const double rms_bowed = Rms(Project(k, cam_from_target, bowed), found);
    const double rms_flat = Rms(Project(k, cam_from_target, flat), found);
    EXPECT_LT(rms_bowed, 0.12) << "eye " << e;
    EXPECT_GT(rms_flat, rms_bowed + 0.15) << "eye " << e;
  }
}

TEST(RollingShutter, AMovingBoardIsDrawnAtEachRowsTime) {
  SceneDescription scene = DefaultScene();
  SceneTarget* board = scene.Find("chessboard");
  board->base_from_target = FacingPose(board->definition, {0.0, 0.0, 0.5}, 10, 5, 0);
  board->motion.speed_m_s = 0.25;
  board->motion.angular_speed_deg_s = 0;
  board->motion.seed = 4;
  RobotTruth truth = DefaultRobotTruth();
  truth.stream.rolling_shutter_ms = 30;
  VirtualOwlOptions o = Clean(scene);
  o.truth = truth;
  VirtualOwl owl(o);
  owl.SetTargetVisible("aprilgrid", false);
  owl.SetTargetVisible("fixation", false);
  const auto frame = owl.GrabFrame(0, 1'000'000'000);
  ASSERT_TRUE(frame.has_value());
  const FrameTruth ft = owl.TruthForFrame(frame->seq);
  const SceneDescription state = owl.SceneState();
  const SceneTarget* t = state.Find("chessboard");
  const calib::TargetDetection d = calib::DetectTarget(frame->left, t->definition, {});
  if (const char* dump = std::getenv("OWLCAL_SIM_DUMP")) cv::imwrite(std::string(dump) + "/rolling.png", frame->left);
  ASSERT_TRUE(d.found) << d.message;
  const auto k = owl.Truth().intrinsics[0];
  const double row_ns = 30e6 / k.height;
  // Each corner predicted from the board's pose when its row was exposed (two passes: the row
  // comes from the prediction itself), against the pose at the frame's exposure.
  double rolled = 0, frozen = 0;
  const auto corners = t->definition.Corners();
  for (size_t i = 0; i < d.pixels.size(); ++i) {
    const Eigen::Vector3d p = t->WarpedPoint(corners.at(d.corner_ids[i]));  // on the (bowed) board
    auto predict = [&](int64_t t_ns) {
      return Project(k, ft.cam_from_base[0].Matrix() * t->PoseAt(t_ns).matrix(), {p})[0];
    };
    cv::Point2f q = predict(ft.exposure_ns[0]);
    const cv::Point2f q0 = q;
    for (int pass = 0; pass < 2; ++pass) q = predict(ft.exposure_ns[0] + int64_t(q.y * row_ns));
    rolled += std::pow(q.x - d.pixels[i].x(), 2) + std::pow(q.y - d.pixels[i].y(), 2);
    frozen += std::pow(q0.x - d.pixels[i].x(), 2) + std::pow(q0.y - d.pixels[i].y(), 2);
  }
  rolled = std::sqrt(rolled / d.pixels.size());
  frozen = std::sqrt(frozen / d.pixels.size());
  EXPECT_LT(rolled, 0.2);
  EXPECT_GT(frozen, rolled + 0.5);
}

TEST(RobotPrior, DrawsValidRobotsAcrossTheDocumentedRanges) {
  std::mt19937_64 rng(11);
  int five_us = 0;
  double f_lo = 1e9, f_hi = 0;
  for (int i = 0; i < 60; ++i) {
    const DrawnRobot r = DrawRobot(&rng, std::to_string(i));  // validates, or throws
    const RobotTruth& t = r.truth;
    five_us += t.servos[0].quantum_us == 5;
    for (int e = 0; e < 2; ++e) {
      const double f = t.intrinsics[e].params[0];
      f_lo = std::min(f_lo, f);
      f_hi = std::max(f_hi, f);
      EXPECT_GE(f, 480);
      EXPECT_LE(f, 620);
      const Eigen::Vector3d cam_in_eye = t.geometry.cam_from_eye[e].Inverse().translation;
      EXPECT_LE(std::abs(cam_in_eye.x()), 0.002);
      EXPECT_LE(std::abs(cam_in_eye.y()), 0.002);
      EXPECT_LE(Eigen::AngleAxisd(t.geometry.cam_from_eye[e].rotation).angle() * 180 / M_PI, 1.5 * std::sqrt(3) + 1e-9);
    }
    EXPECT_GE(t.geometry.Ipd(), 0.0624);
    EXPECT_LE(t.geometry.Ipd(), 0.0657);
    for (int s = 0; s < models::kNumServos; ++s) {
      EXPECT_LE(std::abs(t.servos[s].centre_us - t.robot.servos[s].centre_us), 60);
      EXPECT_GE(t.servos[s].dead_band_us, 1);
      EXPECT_LE(t.servos[s].dead_band_us, 5);
    }
    EXPECT_LE(r.scene.Find("chessboard")->warp_m.x(), 1.2e-3);
  }
  EXPECT_GT(five_us, 5);
  EXPECT_LT(f_lo, 500);
  EXPECT_GT(f_hi, 600);
  std::mt19937_64 a(3), b(3);
  EXPECT_EQ(RobotTruthYaml(DrawRobot(&a, "x").truth), RobotTruthYaml(DrawRobot(&b, "x").truth));
}

TEST(HandHeldCapture, WritesPairsWithTheBoardInBothEyes) {
  VirtualOwlOptions o;
  o.seed = 2;
  VirtualOwl owl(o);
  const std::string dir = (std::filesystem::temp_directory_path() / "owlcal_handheld_test").string();
  std::filesystem::remove_all(dir);
  HandHeldCaptureOptions ho;
  ho.num_pairs = 4;
  const HandHeldCapture c = CaptureHandHeldSet(&owl, dir, ho);
  ASSERT_EQ(c.left_paths.size(), 4u);
  const calib::TargetDefinition def = owl.SceneState().Find("chessboard")->definition;
  int found = 0;
  for (size_t i = 0; i < c.left_paths.size(); ++i)
    for (const auto& p : {c.left_paths[i], c.right_paths[i]})
      found += calib::DetectTarget(cv::imread(p), def, {}).found;
  EXPECT_GE(found, 7);
  EXPECT_FALSE(owl.SceneState().Find("aprilgrid")->visible);
  EXPECT_TRUE(owl.SceneState().Find("chessboard")->motion.Still());  // let go at the end
  std::filesystem::remove_all(dir);
  ho.num_pairs = 0;
  std::string why;
  EXPECT_FALSE(ho.Check(&why));
  EXPECT_NE(why.find("num_pairs"), std::string::npos);
  EXPECT_THROW(CaptureHandHeldSet(&owl, dir, ho), std::invalid_argument);
}

TEST(SceneFile, WarpAndMotionRoundTripAndBadValuesNameTheField) {
  SceneDescription scene = DefaultScene();
  SceneTarget* board = scene.Find("chessboard");
  board->warp_m = Eigen::Vector2d(0.9e-3, -0.2e-3);
  board->motion.speed_m_s = 0.02;
  board->motion.angular_speed_deg_s = 1.5;
  board->motion.seed = 12;
  const std::string dir = (std::filesystem::temp_directory_path() / "owlcal_scene_file_test").string();
  std::filesystem::create_directories(dir);
  const std::string path = dir + "/scene.yaml";
  std::ofstream(path) << SceneJson(scene).dump(2);
  const SceneDescription back = LoadScene(path);
  const SceneTarget* b = back.Find("chessboard");
  ASSERT_NE(b, nullptr);
  EXPECT_DOUBLE_EQ(b->warp_m.x(), 0.9e-3);
  EXPECT_DOUBLE_EQ(b->warp_m.y(), -0.2e-3);
  EXPECT_DOUBLE_EQ(b->motion.speed_m_s, 0.02);
  EXPECT_DOUBLE_EQ(b->motion.angular_speed_deg_s, 1.5);
  EXPECT_EQ(b->motion.seed, 12u);
  EXPECT_TRUE(b->PoseAt(2'000'000'000).isApprox(board->PoseAt(2'000'000'000)));
  EXPECT_TRUE(back.Find("aprilgrid")->motion.Still());
  // A board thrown at 3 m/s, a bow of 10 cm: errors naming the field.
  auto expect_error = [&](const std::string& text, const std::string& field) {
    std::ofstream(path) << text;
    try {
      LoadScene(path);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const std::exception& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  const std::string head = "targets:\n  - name: chessboard\n    kind: chessboard\n";
  expect_error(head + "    motion: {speed_m_s: 3.0, angular_speed_deg_s: 1, seed: 1}\n", "speed_m_s");
  expect_error(head + "    motion: {speed_m_s: 0.1, angular_speed_deg_s: 1, seed: 1, jitter: 2}\n", "jitter");
  expect_error(head + "    warp_m: [0.1, 0]\n", "warp_m");
  expect_error(head + "    warp_m: [0.001]\n", "warp_m");
  std::filesystem::remove_all(dir);
}

TEST(RobotTruthFile, MeasuredStreamRoundTripsAndOlderFilesKeepTheCleanDefaults) {
  RobotTruth t = DefaultRobotTruth();
  t.stream = MeasuredOwlStream();
  const std::string path = (std::filesystem::temp_directory_path() / "owlcal_realism_truth.yaml").string();
  SaveRobotTruth(t, path);
  const RobotTruth u = LoadRobotTruth(path);
  EXPECT_EQ(u.stream.white_level, 160);
  EXPECT_EQ(u.stream.black_level, 60);
  EXPECT_EQ(u.stream.rolling_shutter_ms, 30);
  EXPECT_EQ(RobotTruthYaml(t), RobotTruthYaml(u));
  // A file written before the levels and the rolling shutter existed.
  std::string text = RobotTruthYaml(t);
  for (const char* key : {"white_level", "black_level", "rolling_shutter_ms", "aperture_mm", "focus_m"}) {
    const size_t at = text.find(std::string(key) + ":");
    ASSERT_NE(at, std::string::npos) << key;
    const size_t line = text.rfind('\n', at) + 1;  // the whole line, its indentation too
    text.erase(line, text.find('\n', at) + 1 - line);
  }
  std::ofstream(path) << text;
  const RobotTruth old = LoadRobotTruth(path);
  EXPECT_EQ(old.stream.white_level, StreamTruth().white_level);
  EXPECT_EQ(old.stream.rolling_shutter_ms, 0);
  EXPECT_EQ(old.stream.aperture_mm, 0);  // no defocus in files from before the lens had one
  // Levels that cannot be: ink brighter than paper.
  t.stream.black_level = 200;
  std::ofstream(path) << RobotTruthYaml(t);
  try {
    LoadRobotTruth(path);
    ADD_FAILURE() << "ink brighter than paper accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("white_level"), std::string::npos) << e.what();
  }
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace owlcal::sim
