#include "sim/handheld_capture.h"

#include <cmath>
#include <filesystem>
#include <random>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

namespace owlcal::sim {

bool HandHeldCaptureOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = "HandHeldCaptureOptions." + m;
    return false;
  };
  if (num_pairs < 1 || num_pairs > 1000) return fail("num_pairs must be 1..1000, got " + std::to_string(num_pairs));
  if (!(distance_min_m > 0.1 && distance_max_m >= distance_min_m && distance_max_m < 5))
    return fail("distances must satisfy 0.1 < distance_min_m <= distance_max_m < 5");
  if (!(lateral_fraction >= 0 && lateral_fraction <= 1)) return fail("lateral_fraction must be in [0, 1]");
  if (!(tilt_sigma_deg >= 0 && tilt_sigma_deg <= 60)) return fail("tilt_sigma_deg must be in [0, 60]");
  if (!(roll_max_deg >= 0 && roll_max_deg <= 90)) return fail("roll_max_deg must be in [0, 90]");
  if (!(margin_px >= 0)) return fail("margin_px must be >= 0");
  if (!(held_speed_m_s >= 0 && held_speed_m_s < 2 && held_angular_speed_deg_s >= 0 && held_angular_speed_deg_s < 360))
    return fail("held speeds must be in [0, 2) m/s and [0, 360) deg/s");
  if (!(settle_ms >= 0)) return fail("settle_ms must be >= 0");
  if (jpeg_quality < 1 || jpeg_quality > 100) return fail("jpeg_quality must be 1..100");
  return true;
}

HandHeldCapture CaptureHandHeldSet(VirtualOwl* owl, const std::string& out_dir, const HandHeldCaptureOptions& o) {
  std::string why;
  if (!o.Check(&why)) throw std::invalid_argument(why);
  const SceneDescription scene = owl->SceneState();
  const SceneTarget* target = scene.Find(o.target);
  if (!target) throw std::invalid_argument("CaptureHandHeldSet: no scene target named '" + o.target + "'");
  const calib::TargetDefinition def = target->definition;
  for (const SceneTarget& t : scene.targets)
    if (t.name() != o.target) owl->SetTargetVisible(t.name(), false);
  owl->SetTargetVisible(o.target, true);
  std::filesystem::create_directories(out_dir);

  // Eyes at the robot file's centre, settled.
  owl->SendServos(owl->Config().Centre());
  owl->SleepNs(1'000'000'000);
  const models::JointAngles angles = owl->JointAnglesAt(owl->NowNs());
  const RobotTruth& truth = owl->Truth();
  const double half_fov_x = std::atan2(truth.intrinsics[0].width / 2.0, truth.intrinsics[0].params[0]);
  const double half_fov_y = std::atan2(truth.intrinsics[0].height / 2.0, truth.intrinsics[0].params[1]);

  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> uni(0, 1);
  std::normal_distribution<double> normal(0, 1);
  auto inside_both = [&](const Eigen::Isometry3d& base_from_target) {
    for (int e = 0; e < 2; ++e) {
      const models::Rigid3d cam_from_base = owl->CamFromBase(models::Eye(e), angles);
      const models::CameraIntrinsics& k = truth.intrinsics[e];
      for (const auto& [id, p] : def.Corners()) {
        const Eigen::Vector3d in_cam = cam_from_base * (base_from_target * p);
        double px[2];
        if (!k.Project(in_cam.data(), px)) return false;
        if (px[0] < o.margin_px || px[1] < o.margin_px || px[0] > k.width - 1 - o.margin_px ||
            px[1] > k.height - 1 - o.margin_px)
          return false;
      }
    }
    return true;
  };

  HandHeldCapture out;
  for (int k = 0; k < o.num_pairs; ++k) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    for (int attempt = 0; attempt < 200; ++attempt) {
      const double d = o.distance_min_m + (o.distance_max_m - o.distance_min_m) * uni(rng);
      const double ax = (2 * uni(rng) - 1) * o.lateral_fraction * half_fov_x;
      const double ay = (2 * uni(rng) - 1) * o.lateral_fraction * half_fov_y;
      const Eigen::Vector3d centre(d * std::tan(ax), d * std::tan(ay), d);
      const double tilt = std::abs(normal(rng)) * o.tilt_sigma_deg;
      const double phi = 2 * M_PI * uni(rng);
      const double roll = (2 * uni(rng) - 1) * o.roll_max_deg;
      // Facing the robot along the line of sight, then tilted.
      pose = FacingPose(def, centre, tilt * std::cos(phi) + ax * 180 / M_PI, tilt * std::sin(phi), roll);
      if (inside_both(pose)) break;
    }
    owl->SetTargetPose(o.target, pose);
    TargetMotion m;
    if (o.hand_held) {
      m.speed_m_s = o.held_speed_m_s;
      m.angular_speed_deg_s = o.held_angular_speed_deg_s;
      m.seed = o.seed * 100003 + uint64_t(k);
    }
    owl->SetTargetMotion(o.target, m);
    owl->SleepNs(int64_t(o.settle_ms * 1e6));
    const auto frame = owl->GrabFrame(owl->NowNs(), 2'000'000'000);
    if (!frame || frame->left.empty() || frame->right.empty())
      throw std::runtime_error("CaptureHandHeldSet: no frame from the virtual Owl for pair " + std::to_string(k));
    const std::string l = out_dir + "/left" + std::to_string(k) + ".jpg";
    const std::string r = out_dir + "/right" + std::to_string(k) + ".jpg";
    const std::vector<int> params = {cv::IMWRITE_JPEG_QUALITY, o.jpeg_quality};
    if (!cv::imwrite(l, frame->left, params)) throw std::runtime_error("CaptureHandHeldSet: cannot write " + l);
    if (!cv::imwrite(r, frame->right, params)) throw std::runtime_error("CaptureHandHeldSet: cannot write " + r);
    out.left_paths.push_back(l);
    out.right_paths.push_back(r);
    out.base_from_target.push_back(pose);
  }
  owl->SetTargetMotion(o.target, TargetMotion());
  return out;
}

}  // namespace owlcal::sim
