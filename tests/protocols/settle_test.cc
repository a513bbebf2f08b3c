// Settle detection from the images: after a large move, the first frame recorded after an
// image-based settle shows the servo at its final angle (virtual Owl truth), although the
// stream has 100 ms latency and the servo slews and lags.
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "models/head_model.h"
#include "protocols/dataset.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "sim/virtual_owl.h"

namespace owlcal::protocols {
namespace {
namespace fs = std::filesystem;

TEST(Settle, ImageRuleWaitsUntilTheServoReachedItsCommand) {
  sim::VirtualOwl owl(sim::VirtualOwlOptions{});
  const Protocol p = ParseProtocolYaml(R"(
name: settle
steps:
  - move-to: {pose: {}, settle: {mode: time, time_ms: 500}}
  - move-to: {pose: {Rx: centre+200, Lx: centre-150, Neck: centre+120}, frames: 1,
              settle: {mode: image, min_ms: 100, max_ms: 3000, still_px: 0.3, still_frames: 2}}
  - move-to: {pose: {Ry: centre-120}, frames: 1,
              settle: {mode: image, min_ms: 100, max_ms: 3000, still_px: 0.3, still_frames: 2}}
)",
                                       "settle.yaml");
  RunOptions o;
  o.out_dir = (fs::temp_directory_path() / ("owlcal_settle_" + std::to_string(::getpid()))).string();
  fs::remove_all(o.out_dir);
  const RunSummary s = RunProtocols({p}, owl, o);
  ASSERT_EQ(s.status, "complete") << s.message;
  const auto frames = ReadFramesCsv(o.out_dir);
  ASSERT_EQ(frames.size(), 2u);
  const models::HeadModel head = owl.TruthHeadModel();
  for (const FrameRecord& f : frames) {
    const sim::FrameTruth t = owl.TruthForFrame(f.seq);
    std::array<double, models::kNumServos> pwm;
    std::array<int, models::kNumServos> approach;
    for (int i = 0; i < models::kNumServos; ++i) {
      pwm[i] = f.pwm_us[i];
      approach[i] = f.approach[i];
    }
    const models::JointAngles final_angles = head.Angles(pwm, approach);
    const double deg = 180 / M_PI;
    for (int e = 0; e < 2; ++e) {
      EXPECT_NEAR(t.angles[e].pan_rad[e] * deg, final_angles.pan_rad[e] * deg, 0.05) << "frame " << f.frame_index;
      EXPECT_NEAR(t.angles[e].tilt_rad[e] * deg, final_angles.tilt_rad[e] * deg, 0.05) << "frame " << f.frame_index;
      EXPECT_NEAR(t.angles[e].neck_rad * deg, final_angles.neck_rad * deg, 0.05) << "frame " << f.frame_index;
    }
  }
}

}  // namespace
}  // namespace owlcal::protocols
