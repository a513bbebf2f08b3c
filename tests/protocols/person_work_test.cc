// The person's work and the robot's time (protocols/person_work.h): a target left where it is
// counts once, hide_others takes the others away (tag sheets stay), and two protocols recorded on
// the virtual Owl show, counted from their datasets, the placements and open-loop time planned.
#include "protocols/person_work.h"

#include <unistd.h>

#include <filesystem>

#include <gtest/gtest.h>

#include "protocols/runner.h"
#include "sim/virtual_owl.h"

namespace owlcal::protocols {
namespace {

namespace fs = std::filesystem;

Eigen::Isometry3d At(double x, double z) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = Eigen::Vector3d(x, 0, z);
  return t;
}

TEST(SceneState, ATargetLeftWhereItIsCountsOnce) {
  SceneState scene;
  EXPECT_TRUE(scene.Place("board", At(0, 0.6), false, {}));
  EXPECT_FALSE(scene.Place("board", At(0.0005, 0.6), false, {}));  // within 1 mm: where it was
  EXPECT_TRUE(scene.Place("board", At(0.01, 0.6), false, {}));
  Eigen::Isometry3d turned = At(0.01, 0.6);
  turned.rotate(Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitY()));
  EXPECT_TRUE(scene.Place("board", turned, false, {}));
}

TEST(SceneState, HideOthersTakesTheOthersAwayButNotTheTagSheets) {
  SceneState scene;
  EXPECT_TRUE(scene.Place("tags", At(0.3, 0.7), false, {}));
  EXPECT_TRUE(scene.Place("disc", At(0, 1.0), false, {}));
  // The board where it is asked for, the disc taken away: the scene changed although the board
  // goes where nothing stood.
  EXPECT_TRUE(scene.Place("board", At(0, 0.6), true, {"tags"}));
  EXPECT_FALSE(scene.Place("board", At(0, 0.6), true, {"tags"}));
  EXPECT_FALSE(scene.Place("tags", At(0.3, 0.7), false, {}));  // kept
  EXPECT_TRUE(scene.Place("disc", At(0, 1.0), false, {}));     // taken away before: placed again
  // Without keep, hide_others takes the sheet away too.
  EXPECT_TRUE(scene.Place("board", At(0, 0.6), true, {}));
  EXPECT_TRUE(scene.Place("tags", At(0.3, 0.7), false, {}));
}

// Three place-target steps, one of which leaves the disc where it is; open-loop steps and a
// closed-loop fixation.
const char* kFirst = R"(
name: first
target: fixation
targets:
  fixation: {target_type: fixation, fixation_radius_m: 0.012}
steps:
  - move-to: {pose: {}, settle: {mode: time, time_ms: 300}}
  - place-target: {target: fixation, distance_m: 1.0}
  - grid: {eyes: both, pan_us: [-40, 40], tilt_us: [-30, 30], frames: 2, settle: {mode: time, time_ms: 200}}
  - place-target: {target: fixation, distance_m: 1.0}
  - fixate: {eyes: both, gain: 0.1, max_iterations: 60, tolerance_px: 1.5}
  - place-target: {target: fixation, distance_m: 0.6}
  - capture: {frames: 3, settle: {mode: time, time_ms: 100}}
)";

// Recorded after kFirst: the disc stays at 0.6 m (not a placement), the chessboard takes it away,
// and putting it back counts again.
const char* kSecond = R"(
name: second
target: chessboard
targets:
  chessboard: {target_type: chessboard, cols: 9, rows: 6, square_size_m: 0.026}
  fixation: {target_type: fixation, fixation_radius_m: 0.012}
steps:
  - place-target: {target: fixation, distance_m: 0.6, hide_others: false}
  - place-target: {target: chessboard, distance_m: 0.55}
  - sweep: {servo: Rx, from: centre-60, to: centre+60, step_us: 30, settle: {mode: time, time_ms: 150}}
  - place-target: {target: fixation, distance_m: 0.6}
  - wait: {ms: 250}
)";

TEST(PersonWork, TheDatasetsCountThePlacementsAndOpenLoopTimeThePlanSays) {
  const std::vector<Protocol> protocols = {ParseProtocolYaml(kFirst, "first.yaml"),
                                           ParseProtocolYaml(kSecond, "second.yaml")};
  sim::VirtualOwl owl(sim::VirtualOwlOptions{});
  const models::RobotConfig config = owl.Config();
  SceneState planned_scene, counted_scene;
  const fs::path root = fs::temp_directory_path() / ("owlcal_person_work_" + std::to_string(::getpid()));
  fs::remove_all(root);
  std::vector<ProtocolWork> planned, counted;
  for (const Protocol& p : protocols) {
    planned.push_back(PlanWork(p, config, &planned_scene));
    RunOptions o;
    o.out_dir = (root / p.name).string();
    const RunSummary s = RunProtocols({p}, owl, o);
    ASSERT_EQ(s.status, "complete") << s.message;
    counted.push_back(CountWork(o.out_dir, &counted_scene));
  }
  fs::remove_all(root);

  EXPECT_EQ(planned[0].placement_steps, 3);
  EXPECT_EQ(planned[0].placements, 2);
  EXPECT_EQ(planned[1].placement_steps, 3);
  EXPECT_EQ(planned[1].placements, 2);
  EXPECT_EQ(planned[0].closed_loop_steps, 1);
  EXPECT_EQ(planned[1].closed_loop_steps, 0);
  for (size_t i = 0; i < protocols.size(); ++i) {
    const ProtocolWork &p = planned[i], &c = counted[i];
    EXPECT_EQ(c.protocol, p.protocol);
    EXPECT_EQ(c.placements, p.placements) << p.protocol;
    EXPECT_EQ(c.placement_steps, p.placement_steps) << p.protocol;
    EXPECT_EQ(c.closed_loop_steps, p.closed_loop_steps) << p.protocol;
    EXPECT_EQ(c.steps_not_done, 0) << p.protocol;
    // The open-loop steps took the planned time to within a frame period per step (the phase
    // of the stream's frames); the closed-loop fixation took some time of its own.
    EXPECT_NEAR(c.robot_time_s - c.closed_loop_s, p.robot_time_s, 4 * kNominalFramePeriodS) << p.protocol;
    EXPECT_GT(p.robot_time_s, 0.5) << p.protocol;
  }
  EXPECT_GT(counted[0].closed_loop_s, 0.1);
  EXPECT_EQ(counted[1].closed_loop_s, 0);
  const std::vector<std::string> lines = WorkLines(counted, false);
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_NE(lines[2].find("4 placements ( 6 place-target steps)"), std::string::npos) << lines[2];
}

}  // namespace
}  // namespace owlcal::protocols
