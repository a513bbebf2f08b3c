// Consistency of the virtual Owl's servo-sweep data with models::HeadModel (issue 6 debugging).
//
// Runs the standard servo_sweep protocol on the in-process virtual Owl, then for every
// detected corner compares the detected pixel with
//   (a) the sim's own truth for the frame: VirtualOwl::TruthForFrame(seq).cam_from_base and the
//       recorded target placement, projected with the true intrinsics (is the rendering right?);
//   (b) the truth head model at the RECORDED command and approach:
//       TruthHeadModel().Project(eye, Angles(pwm, approach), x_in_base) (does the recorded
//       command explain the true angles?).
// Also the true joint angles at exposure against TruthHeadModel().Angles(pwm, approach), per
// servo. Then fits the head (fitting::FitHead, true intrinsics, one board per placement via
// protocols::ReadViewsByPlacement) and compares it with the truth in the fit's gauge
// (fitting::CanonicalHead).
// Found with it (issue 6): frames were exposed before the servos settled (settle 250 ms
// minus 100 ms stream latency; 0.1-1.3 deg errors), and the sweep's two placements of one
// chessboard were fitted as one fixed board (head RMS 0.3 px, IPD 55 mm).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <set>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

#include "calib/observation.h"
#include "calib/observation_io.h"
#include "fitting/head_fit.h"
#include "protocols/dataset.h"
#include "protocols/placement_views.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "sim/virtual_owl.h"

namespace owlcal {
namespace {

struct Rms {
  double sum_sq = 0;
  double max = 0;
  int n = 0;
  void Add(double e) {
    sum_sq += e * e;
    max = std::max(max, std::abs(e));
    ++n;
  }
  double Value() const { return std::sqrt(sum_sq / std::max(1, n)); }
};

class HeadSimConsistency : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    sim::VirtualOwlOptions vo;
    vo.seed = 1;
    owl_ = new sim::VirtualOwl(vo);
    // As after an earlier protocol: every servo left at its centre approached from above (the
    // backlash taken up the other way than the sweep's runner could assume).
    models::PwmVector above = owl_->Config().Centre();
    for (int& u : above) u += 40;
    owl_->SendServos(above);
    owl_->SleepNs(500'000'000);
    owl_->SendServos(owl_->Config().Centre());
    owl_->SleepNs(500'000'000);
    dir_ = (std::filesystem::temp_directory_path() / ("owlcal_head_sim_" + std::to_string(::getpid()))).string();
    std::filesystem::remove_all(dir_);
    protocols::RunOptions o;
    o.out_dir = dir_;
    o.robot_spec = "sim";
    o.sim = {{"seed", 1}};
    // The sim keeps ~10 s of servo history: take each frame's truth when it is recorded (the
    // newest received frame at that moment is the one the runner grabbed).
    truth_ = new std::map<int64_t, sim::FrameTruth>;
    o.on_frame = [](int64_t) {
      const int64_t now = owl_->NowNs();
      int64_t seq = int64_t(double(now) * owl_->Truth().stream.fps * 1e-9);
      while (seq > 0 && owl_->StampNs(seq) > now) --seq;
      for (int64_t s = std::max<int64_t>(0, seq - 2); s <= seq; ++s) (*truth_)[s] = owl_->TruthForFrame(s);
    };
    summary_ = new protocols::RunSummary(protocols::RunProtocols(
        {protocols::LoadProtocolFile(protocols::ResolveProtocolPath("servo_sweep"))}, *owl_, o));
  }
  static void TearDownTestSuite() {
    std::filesystem::remove_all(dir_);
    delete owl_;
    delete summary_;
    delete truth_;
  }
  static sim::VirtualOwl* owl_;
  static protocols::RunSummary* summary_;
  static std::string dir_;
  static std::map<int64_t, sim::FrameTruth>* truth_;
};
std::map<int64_t, sim::FrameTruth>* HeadSimConsistency::truth_ = nullptr;
sim::VirtualOwl* HeadSimConsistency::owl_ = nullptr;
protocols::RunSummary* HeadSimConsistency::summary_ = nullptr;
std::string HeadSimConsistency::dir_;

TEST_F(HeadSimConsistency, DetectedCornersMatchTruthAndRecordedCommands) {
  ASSERT_EQ(summary_->status, "complete") << summary_->message;
  const auto frames = protocols::ReadFramesCsv(dir_);
  const auto placements = protocols::ReadPlacementsCsv(dir_);
  const auto views = calib::GroupIntoViews(calib::ReadObservationsCsv(dir_ + "/observations.csv"));
  ASSERT_GT(views.size(), 100u);
  std::map<int64_t, protocols::FrameRecord> frame_of;
  for (const auto& f : frames) frame_of[f.frame_index] = f;
  std::map<int, Eigen::Isometry3d> pose_of;
  for (const auto& p : placements) pose_of[p.placement_index] = p.base_from_target;
  const models::HeadModel head = owl_->TruthHeadModel();

  Rms render[2], model[2], angle_err[models::kNumServos];
  std::map<std::string, Rms> by_step, by_step_angle;
  for (const auto& v : views) {
    const auto& fr = frame_of.at(v.frame_index);
    ASSERT_TRUE(pose_of.count(fr.placement_index)) << "frame " << v.frame_index;
    const Eigen::Isometry3d& base_from_target = pose_of.at(fr.placement_index);
    ASSERT_TRUE(truth_->count(fr.seq)) << "frame " << v.frame_index << " seq " << fr.seq;
    const sim::FrameTruth& ft = truth_->at(fr.seq);
    std::array<double, models::kNumServos> pwm;
    std::array<int, models::kNumServos> approach;
    for (int s = 0; s < models::kNumServos; ++s) {
      pwm[s] = v.pwm_us[s];
      approach[s] = v.approach[s];
    }
    const models::JointAngles a = head.Angles(pwm, approach);
    const int e = v.eye;
    const models::JointAngles& t = ft.angles[e];
    angle_err[models::kPanServo[e]].Add((a.pan_rad[e] - t.pan_rad[e]) * 180 / M_PI);
    angle_err[models::kTiltServo[e]].Add((a.tilt_rad[e] - t.tilt_rad[e]) * 180 / M_PI);
    angle_err[models::kNeck].Add((a.neck_rad - t.neck_rad) * 180 / M_PI);
    const std::string step = std::to_string(fr.step_index) + ":" + fr.step_name;
    by_step_angle[step].Add((a.pan_rad[e] - t.pan_rad[e]) * 180 / M_PI);
    by_step_angle[step].Add((a.tilt_rad[e] - t.tilt_rad[e]) * 180 / M_PI);
    by_step_angle[step].Add((a.neck_rad - t.neck_rad) * 180 / M_PI);
    for (size_t k = 0; k < v.pixels.size(); ++k) {
      const Eigen::Vector3d x_base = base_from_target * v.points_in_target[k];
      const Eigen::Vector3d p_cam = ft.cam_from_base[e] * x_base;
      Eigen::Vector2d px_truth, px_model;
      ASSERT_TRUE(head.intrinsics[e].Project(p_cam.data(), px_truth.data()));
      ASSERT_TRUE(head.Project(models::Eye(e), a, x_base, &px_model));
      render[e].Add((px_truth - v.pixels[k]).norm());
      const double em = (px_model - v.pixels[k]).norm();
      model[e].Add(em);
      by_step[step].Add(em);
    }
  }
  for (int e = 0; e < 2; ++e) {
    std::printf("%s eye: detected vs sim truth RMS %.4f px (max %.3f); vs truth model at recorded command RMS %.4f px (max %.3f)\n",
                models::kEyeNames[e], render[e].Value(), render[e].max, model[e].Value(), model[e].max);
  }
  for (int s = 0; s < models::kNumServos; ++s)
    std::printf("servo %s: model(recorded cmd) - true angle at exposure: RMS %.4f deg, max %.4f deg\n",
                models::kServoNames[s], angle_err[s].Value(), angle_err[s].max);
  for (const auto& [step, r] : by_step)
    std::printf("  step %s: model RMS %.4f px (max %.3f), joint angle error RMS %.4f deg (max %.4f)\n", step.c_str(),
                r.Value(), r.max, by_step_angle[step].Value(), by_step_angle[step].max);
  for (int e = 0; e < 2; ++e) {
    EXPECT_LT(render[e].Value(), 0.15) << "the rendered corners do not follow the sim's own truth";
    EXPECT_LT(model[e].Value(), 0.15) << "the recorded command/approach do not explain the true angles";
  }
  for (int s = 0; s < models::kNumServos; ++s) EXPECT_LT(angle_err[s].Value(), 0.02) << models::kServoNames[s];
}


// The head fit on the same data (true intrinsics held, as after a perfect stereo fit) against
// the truth in the fit's gauge.
TEST_F(HeadSimConsistency, HeadFitRecoversTheTruth) {
  ASSERT_EQ(summary_->status, "complete") << summary_->message;
  // Each board placement is its own fixed board (the sweep places one chessboard twice).
  const auto views = protocols::ReadViewsByPlacement(dir_);
  std::set<std::string> boards;
  for (const auto& v : views) boards.insert(v.target_id);
  EXPECT_EQ(boards, (std::set<std::string>{"chessboard@placement0", "chessboard@placement1"}));
  const models::RobotConfig& config = owl_->Config();
  const models::HeadModel truth = owl_->TruthHeadModel();
  models::HeadModel initial = models::NominalHeadModel(config);
  for (int e = 0; e < 2; ++e) initial.intrinsics[e] = truth.intrinsics[e];
  bool neck_moved = false;
  for (const auto& v : views) neck_moved |= v.pwm_us[models::kNeck] != config.servos[models::kNeck].centre_us;
  fitting::HeadFitOptions ho;
  ho.corner_sigma_px = 0.03;
  const fitting::HeadFit fit = fitting::FitHead(views, config, initial, ho);
  ASSERT_TRUE(fit.ok) << fit.message;
  const models::HeadModel canonical = fitting::CanonicalHead(truth, config.servos[models::kNeck].centre_us, neck_moved,
                                                             initial.geometry.centre_in_head[models::kLeftEye]);
  const double rms = fit.result.summaries.back().rms_px;
  const double ipd_err_mm = 1000 * (fit.head.geometry.Ipd() - truth.geometry.Ipd());
  std::printf("head fit: RMS %.4f px, IPD %.3f mm (truth %.3f, error %.3f mm), %d views\n", rms,
              1000 * fit.head.geometry.Ipd(), 1000 * truth.geometry.Ipd(), ipd_err_mm, fit.num_views_used);
  for (int s = 0; s < models::kNumServos; ++s) {
    const auto& lim = config.servos[s];
    const double lo = s == models::kNeck ? lim.centre_us - 100 : (s == models::kRy || s == models::kLy ? lim.centre_us - 90 : lim.centre_us - 120);
    const double hi = 2 * lim.centre_us - lo;
    const double d = fitting::ServoMapRmsDeg(fit.head.servo_params[s].data(), canonical.servo_params[s].data(),
                                             canonical.directions[s], lo, hi);
    std::printf("servo %s: fitted centre %.2f us (truth %.2f), scale %.5f (truth %.5f), map RMS error %.4f deg\n",
                models::kServoNames[s], fit.head.servo_params[s][0], canonical.servo_params[s][0],
                fit.head.servo_params[s][1], canonical.servo_params[s][1], d);
    EXPECT_LT(d, 0.1) << models::kServoNames[s];
  }
  std::map<int, int> outliers_by_neck;
  std::map<int, int> neck_of_frame;
  for (const auto& v : views) neck_of_frame[v.frame_index] = v.pwm_us[models::kNeck];
  for (const auto& o : fit.outliers) outliers_by_neck[neck_of_frame[o.frame_index]]++;
  std::printf("outliers: %zu of %d corners used\n", fit.outliers.size(), fit.num_corners_used);
  for (const auto& [neck, n] : outliers_by_neck) std::printf("  neck %d us: %d outliers\n", neck, n);
  if (std::getenv("OWLCAL_HEAD_SIM_VERBOSE")) {
    const auto tp = fitting::HeadParameters(canonical, false);
    for (const auto& p : fit.result.parameters)
      for (const auto& t : tp)
        if (t.name == p.name)
          std::printf("  %-32s fit %12.5f  truth %12.5f  sigma %.5f\n", p.name.c_str(), p.value, t.value, p.sigma);
  }
  EXPECT_LT(rms, 0.06);
  EXPECT_LT(std::abs(ipd_err_mm), 0.5);
}

}  // namespace
}  // namespace owlcal
