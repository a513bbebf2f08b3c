// The statistics that compare a real Owl's image set with the virtual Owl's: on the course's
// kit2020 set they give what bench/sim_real_bench.cc reports, and on a virtual set they recover
// the board warp the scene was given. Pooled sigma coverage is grouped by parameter kind.
#include "fitting/capture_stats.h"

#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "fitting/monte_carlo.h"
#include "sim/handheld_capture.h"
#include "sim/virtual_owl.h"
#include "tests/shared_data.h"

namespace owlcal::fitting {
namespace {

calib::TargetDefinition KitBoard() {
  calib::TargetDefinition b;
  b.cols = 9;
  b.rows = 6;
  b.square_m = 0.026;
  return b;
}

TEST(CaptureStats, Kit2020LooksLikeARealOwl) {
  // The warp search (about 150 fits) is left to the bench: 0.84 mm on this set.
  CaptureStatsOptions o;
  o.measure_warp = false;
  const CaptureStats s =
      MeasureCapture("kit2020", test_data::SharedData() + "/owl-real/kit2020-chessboard", {}, KitBoard(), o);
  EXPECT_EQ(s.num_images, 54);
  EXPECT_EQ(s.num_found, 54);
  EXPECT_EQ(s.num_pairs_used, 27);
  EXPECT_NEAR(s.view_rms_px.median, 0.17, 0.03);
  EXPECT_NEAR(s.stereo_rms_joint_px, 0.40, 0.05);  // the held board moved between the eyes
  EXPECT_GT(s.stereo_over_mono_rms, 1.5);
  EXPECT_NEAR(s.noise_white.median, 0.9, 0.3);
  EXPECT_NEAR(s.edge_sigma_px.median, 0.53, 0.05);
  EXPECT_NEAR(s.white_level.median, 160, 10);
  EXPECT_NEAR(s.black_level.median, 62, 10);
  EXPECT_EQ(s.jpeg_quality, 95);
  EXPECT_NEAR(s.blockiness.median, 1.08, 0.04);
  EXPECT_NEAR(s.distance_m.median, 0.64, 0.05);
  // Brightness falling towards the image corners: one brightness per image reads 0.14, with a
  // light gradient across each board besides 0.53 (the room's light and the lens part only so).
  EXPECT_NEAR(s.lens_shading, 0.14, 0.05);
  EXPECT_NEAR(s.lens_shading_curvature, 0.53, 0.08);
  EXPECT_TRUE(s.problems.empty()) << s.problems.front();
}

TEST(CaptureStats, RecoversTheWarpAndJitterOfAVirtualHeldBoard) {
  sim::VirtualOwlOptions o;
  o.seed = 4;
  sim::RobotTruth truth = sim::DefaultRobotTruth();
  truth.stream = sim::MeasuredOwlStream();
  o.truth = truth;
  sim::SceneDescription scene = sim::DefaultScene();
  scene.Find("chessboard")->warp_m = Eigen::Vector2d(1.2e-3, 0);
  o.scene = scene;
  sim::VirtualOwl owl(o);
  const std::string dir = (std::filesystem::temp_directory_path() / "owlcal_capture_stats_test").string();
  std::filesystem::remove_all(dir);
  sim::HandHeldCaptureOptions ho;
  ho.num_pairs = 10;
  sim::CaptureHandHeldSet(&owl, dir, ho);
  const CaptureStats held = MeasureCapture("held", dir, {}, KitBoard());
  std::filesystem::remove_all(dir);
  EXPECT_GE(held.num_found, 18);
  EXPECT_NEAR(held.warp_mm[0], 1.2, 0.3);
  EXPECT_NEAR(held.warp_mm[1], 0.0, 0.3);
  EXPECT_NEAR(held.white_level.median, 160, 8);
  // Uniform light: both shading estimates find the lens's.
  EXPECT_NEAR(held.lens_shading, truth.stream.lens_shading, 0.04);
  EXPECT_NEAR(held.lens_shading_curvature, truth.stream.lens_shading, 0.06);
  // A still board: the eyes agree far better than on a held one.
  ho.hand_held = false;
  sim::CaptureHandHeldSet(&owl, dir, ho);
  CaptureStatsOptions co;
  co.measure_warp = false;
  const CaptureStats still = MeasureCapture("still", dir, {}, KitBoard(), co);
  std::filesystem::remove_all(dir);
  EXPECT_EQ(still.warp_mm[0], 0);
  EXPECT_LT(still.jitter_mm.median, 0.5 * held.jitter_mm.median);
  EXPECT_LT(still.stereo_over_mono_rms, held.stereo_over_mono_rms);
}

TEST(SigmaCoverage, PoolsZPerParameterGroup) {
  EXPECT_EQ(ParameterGroup("left.fx"), "lens");
  EXPECT_EQ(ParameterGroup("head.right.k1"), "lens");
  EXPECT_EQ(ParameterGroup("stereo.baseline_mm"), "stereo");
  EXPECT_EQ(ParameterGroup("servo.Rx.centre_us"), "servo maps");
  EXPECT_EQ(ParameterGroup("head.ipd_mm"), "head geometry");
  EXPECT_EQ(ParameterGroup("head.left.mount_yaw_deg"), "head geometry");
  SigmaCoverage c;
  c.SetLabel("robot 1");
  std::vector<Parameter> ps;
  for (int i = 0; i < 100; ++i) {
    Parameter p;
    p.name = "servo.Rx.centre_us";
    p.sigma = 1;
    p.truth = 0;
    p.value = i < 68 ? 0.5 : (i < 90 ? 1.5 : (i < 99 ? 2.5 : -4));  // 68 % within 1, 90 % within 2, 99 % within 3
    ps.push_back(p);
  }
  c.Add(ps);
  ASSERT_EQ(c.per_group().count("servo maps"), 1u);
  const auto& g = c.per_group().at("servo maps");
  EXPECT_EQ(g.count, 100);
  EXPECT_EQ(g.within1, 68);
  EXPECT_EQ(g.within2, 90);
  EXPECT_EQ(g.within3, 99);
  EXPECT_DOUBLE_EQ(g.worst_z, 4);
  EXPECT_EQ(g.worst, "robot 1 servo.Rx.centre_us");
  const std::string table = c.GroupTable();
  EXPECT_NE(table.find("| servo maps | 100 | 68.0 % | 90.0 % | 99.00 % |"), std::string::npos) << table;
  EXPECT_NE(table.find("| ok |"), std::string::npos) << table;
}

}  // namespace
}  // namespace owlcal::fitting
