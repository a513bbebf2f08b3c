// The default scene's tag sheets (sim/scene.h DefaultScene, protocols/standard/servo_sweep.yaml
// tag_targets): where the eye has turned so far that the chessboard is cut at the image's
// corner, calib::DetectAprilGrids still finds the sheets' tags that are fully in view, at the
// pixels the truth projects their corners to.
#include <cmath>
#include <cstdlib>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "calib/detector.h"
#include "models/units.h"
#include "sim/virtual_owl.h"

namespace owlcal::sim {
namespace {

// How many of the target's corners the truth projects inside the image, and their pixels by id.
int CornersInImage(const models::HeadModel& head,
                   models::Eye eye,
                   const models::JointAngles& a,
                   const SceneTarget& t,
                   std::map<int, Eigen::Vector2d>* pixels) {
  int inside = 0;
  for (const auto& [id, x] : t.definition.Corners()) {
    Eigen::Vector2d px;
    if (!head.Project(eye, a, t.base_from_target * x, &px)) continue;
    (*pixels)[id] = px;
    inside += px.x() >= 0 && px.x() <= 639 && px.y() >= 0 && px.y() <= 479;
  }
  return inside;
}

TEST(TagSheets, TagsAreDetectedWhereTheChessboardIsCutAtTheImageCorner) {
  VirtualOwlOptions vo;
  vo.seed = 5;
  VirtualOwl owl(vo);
  const models::HeadModel head = owl.TruthHeadModel();
  const SceneDescription scene = owl.SceneState();
  const SceneTarget& chess = *scene.Find("chessboard");
  std::vector<calib::TargetDefinition> sheets;
  for (const char* n : {"tags_right_up", "tags_right_down", "tags_left_up", "tags_left_down"}) {
    ASSERT_NE(scene.Find(n), nullptr) << n;
    sheets.push_back(scene.Find(n)->definition);
  }
  // Each eye turned out and up or down, 17-22 deg and 13-15 deg from its centre pose: the
  // chessboard ahead runs off one corner of the image.
  struct Case {
    models::Eye eye;
    double pan_deg, tilt_deg;
  } cases[] = {{models::kRightEye, 19, 13},
               {models::kRightEye, 17, -15},
               {models::kLeftEye, -18, 14},
               {models::kLeftEye, -22, -14}};
  int num_cases = 0;
  for (const Case& c : cases) {
    models::JointAngles a = head.Angles(owl.Config().Centre());
    a.pan_rad[c.eye] += c.pan_deg * kDeg;
    a.tilt_rad[c.eye] += c.tilt_deg * kDeg;
    std::map<int, Eigen::Vector2d> chess_px;
    const int chess_inside = CornersInImage(head, c.eye, a, chess, &chess_px);
    SCOPED_TRACE(std::string(models::kEyeNames[c.eye]) + " eye pan " + std::to_string(c.pan_deg) + " tilt " +
                 std::to_string(c.tilt_deg) + ": " + std::to_string(chess_inside) +
                 " of 54 chessboard corners in the image");
    // The chessboard is cut: part of it in view, part out.
    EXPECT_GT(chess_inside, 5);
    EXPECT_LT(chess_inside, 54);
    const cv::Mat img = owl.RenderEyeGrey(c.eye, a);
    if (const char* dir = std::getenv("OWLCAL_SIM_DUMP"))
      cv::imwrite(std::string(dir) + "/tag_sheets_" + std::to_string(num_cases) + ".png", img);
    const calib::TargetDetection board = calib::DetectTarget(img, chess.definition, calib::DetectorOptions());
    EXPECT_FALSE(board.found) << board.message;
    const std::vector<calib::TargetDetection> found = calib::DetectAprilGrids(img, sheets, calib::DetectorOptions());
    ASSERT_EQ(found.size(), sheets.size());
    int num_tags = 0;
    double ss = 0, worst = 0;
    for (size_t g = 0; g < sheets.size(); ++g) {
      if (!found[g].found) continue;
      std::map<int, Eigen::Vector2d> truth;
      CornersInImage(head, c.eye, a, *scene.Find(sheets[g].id), &truth);
      num_tags += int(found[g].corner_ids.size()) / 4;
      for (size_t i = 0; i < found[g].corner_ids.size(); ++i) {
        const double err = (found[g].pixels[i] - truth.at(found[g].corner_ids[i])).norm();
        ss += err * err;
        worst = std::max(worst, err);
      }
    }
    const double rms = num_tags ? std::sqrt(ss / (4 * num_tags)) : 0.0;
    std::printf(
        "%s eye pan %+.0f tilt %+.0f deg: chessboard %d of 54 corners in view, not found; %d tags, corner RMS "
        "%.3f px, worst %.3f px\n",
        models::kEyeNames[c.eye],
        c.pan_deg,
        c.tilt_deg,
        chess_inside,
        num_tags,
        rms,
        worst);
    EXPECT_GE(num_tags, 4);
    EXPECT_LT(rms, 0.3);
    EXPECT_LT(worst, 1.0);
    ++num_cases;
  }
  EXPECT_EQ(num_cases, 4);
}

TEST(TagSheets, DetectAprilGridsKeepsEachGridsOwnTags) {
  // Every grid detected alone (DetectTarget) and together (DetectAprilGrids) gives the same corners.
  VirtualOwlOptions vo;
  vo.seed = 6;
  VirtualOwl owl(vo);
  const models::HeadModel head = owl.TruthHeadModel();
  models::JointAngles a = head.Angles(owl.Config().Centre());
  a.pan_rad[models::kRightEye] += 12 * kDeg;
  const cv::Mat img = owl.RenderEyeGrey(models::kRightEye, a);
  std::vector<calib::TargetDefinition> sheets;
  for (const char* n : {"tags_right_up", "tags_right_down", "tags_left_up"})
    sheets.push_back(owl.SceneState().Find(n)->definition);
  const auto together = calib::DetectAprilGrids(img, sheets, calib::DetectorOptions());
  ASSERT_EQ(together.size(), 3u);
  int found = 0;
  for (size_t g = 0; g < sheets.size(); ++g) {
    const calib::TargetDetection alone = calib::DetectTarget(img, sheets[g], calib::DetectorOptions());
    EXPECT_EQ(alone.found, together[g].found) << sheets[g].id;
    EXPECT_EQ(alone.corner_ids, together[g].corner_ids) << sheets[g].id;
    for (int id : together[g].corner_ids) {
      EXPECT_GE(id / 4, sheets[g].first_id);
      EXPECT_LT(id / 4, sheets[g].first_id + 12);
    }
    found += together[g].found;
  }
  EXPECT_GE(found, 2);  // both right-hand sheets
  EXPECT_THROW(
      calib::DetectAprilGrids(img, {owl.SceneState().Find("chessboard")->definition}, calib::DetectorOptions()),
      std::invalid_argument);
}

}  // namespace
}  // namespace owlcal::sim
