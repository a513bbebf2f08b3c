// Limits validation on the virtual Owl finds each servo's true usable range within 10 us.
// The truth of a usable end is the first, going outward from the centre, of: the physical
// end-stop (robot-truth file), the socket rim (computed from the truth geometry: the pulse
// width at which the rim darkens one of the 16 border segments of protocols/image_motion.h by
// the protocol's rim_fraction), and the configured limit of the robot file.
#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "calib/csv.h"
#include "protocols/dataset.h"
#include "protocols/image_motion.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "sim/virtual_owl.h"

namespace owlcal::protocols {
namespace {
namespace fs = std::filesystem;

// The rim "intrudes" when it dims more than rim_fraction (2 %) of the border band's pixels to
// under a quarter of their brightness (the runner sees such pixels fall below grey 20).
constexpr double kDim = 0.25;

// Fraction of the 8 px border band that the rim dims to under `dim` of its brightness, for
// servo `servo` at pulse u.
double TruthRimDarkening(const sim::VirtualOwl& owl, int servo, double u, int approach, double dim) {
  const models::HeadModel head = owl.TruthHeadModel();
  const sim::RobotTruth& truth = owl.Truth();
  const int eye = servo == models::kLx || servo == models::kLy ? models::kLeftEye : models::kRightEye;
  std::array<double, models::kNumServos> pwm;
  std::array<int, models::kNumServos> appr{};
  for (int i = 0; i < models::kNumServos; ++i) pwm[i] = truth.robot.servos[i].centre_us;
  pwm[servo] = u;
  appr[servo] = approach;
  models::JointAngles a = head.Angles(pwm, appr);
  a.neck_rad = 0;  // cam_from_base with the neck at zero is cam_from_head
  const Eigen::Vector3d axis = (owl.CamFromBase(models::Eye(eye), a).rotation * Eigen::Vector3d::UnitZ()).normalized();
  const double cos_start = std::cos((truth.socket.rim_half_angle_deg - truth.socket.rim_softness_deg) * M_PI / 180);
  const double cos_end = std::cos(truth.socket.rim_half_angle_deg * M_PI / 180);
  const models::CameraIntrinsics& k = truth.intrinsics[eye];
  double dark = 0, n = 0;
  {
    const int b = 8;
    std::vector<cv::Point> pts;
    for (int y = 0; y < k.height; y += 2)
      for (int x = 0; x < k.width; x += 2)
        if (x < b || y < b || x >= k.width - b || y >= k.height - b) pts.emplace_back(x, y);
    for (const cv::Point& pt : pts) {
      {
        const double px[2] = {double(pt.x), double(pt.y)};
        double ray[3];
        if (!k.Unproject(px, ray)) continue;
        const double c = Eigen::Vector3d(ray[0], ray[1], ray[2]).normalized().dot(axis);
        double factor = 1;
        if (c < cos_start) {
          double f = std::min(1.0, (cos_start - c) / (cos_start - cos_end));
          f = f * f * (3 - 2 * f);
          factor = 1 - (1 - truth.socket.rim_floor) * f;
        }
        dark += factor < dim;
        ++n;
      }
    }
  }
  return n ? dark / n : 0;
}

// The true usable end of a servo (d = +1 high end, -1 low end) and its cause.
int TruthEnd(const sim::VirtualOwl& owl, int servo, int d, double rim_fraction, std::string* cause) {
  const sim::RobotTruth& t = owl.Truth();
  const models::ServoConfig& c = t.robot.servos[servo];
  const double stop = d > 0 ? t.servos[servo].endstop_hi_us : t.servos[servo].endstop_lo_us;
  for (int u = c.centre_us;; u += d) {
    if (servo != models::kNeck && TruthRimDarkening(owl, servo, u, d, kDim) > rim_fraction) {
      *cause = "rim";
      return u - d;
    }
    if ((d > 0 && u >= stop) || (d < 0 && u <= stop)) {
      *cause = "end-stop";
      return int(std::lround(stop));
    }
    if (u == (d > 0 ? c.max_us : c.min_us)) {
      *cause = "configured";
      return u;
    }
  }
}

void CheckLimits(const sim::VirtualOwlOptions& vo, const std::string& name) {
  sim::VirtualOwl owl(vo);
  const Protocol p = LoadProtocolFile(ResolveProtocolPath("limits"));
  RunOptions o;
  o.out_dir = (fs::temp_directory_path() / ("owlcal_limits_" + name + "_" + std::to_string(::getpid()))).string();
  fs::remove_all(o.out_dir);
  const RunSummary s = RunProtocols({p}, owl, o);
  ASSERT_EQ(s.status, "complete") << s.message;
  EXPECT_EQ(s.num_clamped, 0);
  std::ifstream in(o.out_dir + "/limits.csv");
  std::string line;
  std::getline(in, line);
  int rows = 0;
  while (std::getline(in, line)) {
    const auto f = calib::SplitCsvLine(line);
    const int servo = ServoIndexFromName(f[1]);
    const int d = f[2] == "max" ? 1 : -1;
    const int measured = std::stoi(f[4]);
    std::string cause;
    const int truth = TruthEnd(owl, servo, d, p.steps[1].rim_fraction, &cause);
    std::cout << name << " " << f[1] << " " << f[2] << ": measured " << measured << " (" << f[5] << "), truth " << truth
              << " (" << cause << "), error " << measured - truth << " us\n";
    EXPECT_LE(std::abs(measured - truth), 10) << f[1] << " " << f[2];
    EXPECT_EQ(f[5], cause) << f[1] << " " << f[2];
    ++rows;
  }
  EXPECT_EQ(rows, 10);
}

TEST(Limits, FindsTheTrueUsableRangeWithin10usOnTheDefaultRobot) {
  CheckLimits(sim::VirtualOwlOptions{}, "default");
}

TEST(Limits, FindsEndStopsInsideTheConfiguredRange) {
  sim::VirtualOwlOptions vo;
  sim::RobotTruth t = sim::DefaultRobotTruth();
  t.servos[models::kNeck].endstop_lo_us = 1340;
  t.servos[models::kNeck].endstop_hi_us = 1790;
  t.servos[models::kRx].endstop_hi_us = 1700;
  t.servos[models::kLy].endstop_lo_us = 1480;
  vo.truth = t;
  vo.seed = 3;
  CheckLimits(vo, "endstops");
}

}  // namespace
}  // namespace owlcal::protocols
