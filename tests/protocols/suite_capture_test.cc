// Standard protocols end to end on the in-process virtual Owl: capture protocols.
#include <map>
#include <set>

#include <gtest/gtest.h>

#include "calib/observation_io.h"

#include "tests/protocols/suite_helpers.h"

namespace owlcal::protocols {
namespace {
using testing::ExpectCleanDataset;
using testing::Ran;
using testing::ReadTableRows;
using testing::RunStandard;

TEST(StandardSuite, ServoSweepRecordsBothApproachDirections) {
  const Ran r = RunStandard("servo_sweep");
  ExpectCleanDataset(r);
  const auto frames = ReadFramesCsv(r.dir);
  ASSERT_GT(frames.size(), 50u);
  int up = 0, down = 0;
  std::string first_sweep;  // the Rx sweep (after the backlash take-up moves)
  for (const auto& f : frames)
    if (first_sweep.empty() && f.step_name.rfind("sweep", 0) == 0) first_sweep = f.step_name;
  for (const auto& f : frames) {
    if (f.step_name != first_sweep) continue;
    up += f.approach[models::kRx] > 0;
    down += f.approach[models::kRx] < 0;
  }
  EXPECT_GT(up, 5);
  EXPECT_GT(down, 5);
  EXPECT_EQ(ReadPlacementsCsv(r.dir).size(), 9u);  // 4 tag sheets; the chessboard at 0.6 m, 0.85 m, 0.45 m, +-25 deg
  // The tag sheets (tag_targets) are detected too, also in frames where the chessboard is not:
  // the tilts and the neck near their ends.
  std::map<std::string, int> views_of;
  std::map<std::pair<int, int>, std::set<std::string>> targets_of;  // (frame, eye) -> targets seen
  for (const calib::View& v : calib::GroupIntoViews(calib::ReadObservationsCsv(r.dir + "/observations.csv"))) {
    ++views_of[v.target_id];
    targets_of[{v.frame_index, v.eye}].insert(v.target_id);
  }
  for (const char* sheet : {"tags_right_up", "tags_right_down", "tags_left_up", "tags_left_down"})
    EXPECT_GT(views_of[sheet], 20) << sheet;
  int tags_only = 0;
  for (const auto& [key, targets] : targets_of) tags_only += !targets.count("chessboard");
  EXPECT_GT(tags_only, 30) << "views with tags but no chessboard";  // 41 on seed 1
}

TEST(StandardSuite, IntrinsicsAndStereoRecordFrames) {
  for (const char* name : {"intrinsics", "stereo"}) {
    const Ran r = RunStandard(name);
    ExpectCleanDataset(r);
    EXPECT_GE(r.summary.num_frames, 6);
    // Detection ran during capture: corners of the chessboard in both eyes, and coverage.
    const auto obs = calib::ReadObservationsCsv(r.dir + "/observations.csv");
    EXPECT_GE(obs.size(), size_t(r.summary.num_frames) * 54) << name;  // most frames, both eyes, 54 corners
    const auto coverage = ReadTableRows(r.dir + "/coverage.csv");
    ASSERT_EQ(coverage.size(), 2u) << name;
    if (std::string(name) == "intrinsics") {
      for (const auto& row : coverage) {
        EXPECT_GT(std::stod(row[4]), 0.7) << "X coverage " << row[0];
      }
    }
  }
}

TEST(StandardSuite, AlignmentFindsSmallRollAndOffset) {
  const Ran r = RunStandard("alignment");
  ExpectCleanDataset(r);
  const auto rows = ReadTableRows(r.dir + "/alignment.csv");
  ASSERT_EQ(rows.size(), 3u);
  for (const auto& row : rows) {
    EXPECT_EQ(row[2], "chessboard");
    EXPECT_LT(std::abs(std::stod(row[3])), 5.0);   // roll [deg]
    EXPECT_LT(std::abs(std::stod(row[4])), 20.0);  // vertical offset [px]
  }
}

TEST(StandardSuite, LatencyNearTheStreamLatency) {
  const Ran r = RunStandard("latency");
  ExpectCleanDataset(r);
  const auto rows = ReadTableRows(r.dir + "/latency.csv");
  ASSERT_EQ(rows.size(), 8u);
  for (const auto& row : rows) {
    const double ms = std::stod(row[4]);
    EXPECT_GT(ms, 90.0);
    EXPECT_LT(ms, 200.0);
  }
}

}  // namespace
}  // namespace owlcal::protocols
