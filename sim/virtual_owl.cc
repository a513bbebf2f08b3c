#include "sim/virtual_owl.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "io/number_text.h"

namespace owlcal::sim {
namespace {

using models::kLeftEye;
using models::kNumServos;
using models::kRightEye;

constexpr int64_t kHistoryNs = 10'000'000'000;  // servo history kept for past frames

uint64_t Mix(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

}  // namespace

bool VirtualOwlOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (latency_ms && !(*latency_ms >= 0 && *latency_ms < 10000))
    return fail("latency_ms = " + std::to_string(*latency_ms) + " must be in [0, 10000)");
  if (noise_sigma && !(*noise_sigma >= 0 && *noise_sigma < 100))
    return fail("noise_sigma = " + std::to_string(*noise_sigma) + " must be in [0, 100)");
  if (drop_probability && !(*drop_probability >= 0 && *drop_probability < 1)) {
    return fail("drop_probability = " + std::to_string(*drop_probability) + " must be in [0, 1)");
  }
  if (jpeg_quality && (*jpeg_quality < 1 || *jpeg_quality > 100))
    return fail("jpeg_quality = " + std::to_string(*jpeg_quality) + " must be 1..100");
  if (quantum_us && (*quantum_us < 1 || *quantum_us > 50))
    return fail("quantum_us = " + std::to_string(*quantum_us) + " must be 1..50");
  if (eye_offset_ms && std::abs(*eye_offset_ms) > 30)
    return fail("eye_offset_ms = " + std::to_string(*eye_offset_ms) + " must be within +-30");
  return true;
}

VirtualOwl::VirtualOwl(const VirtualOwlOptions& options)
    : seed_(options.seed),
      encode_jpeg_(options.encode_jpeg),
      decode_frames_(options.decode_frames),
      real_time_(options.real_time) {
  std::string why;
  if (!options.Check(&why)) throw std::invalid_argument("VirtualOwlOptions: " + why);
  truth_ = options.truth ? *options.truth
                         : (options.truth_file.empty() ? DefaultRobotTruth() : LoadRobotTruth(options.truth_file));
  if (options.latency_ms) truth_.stream.latency_ms = *options.latency_ms;
  if (options.noise_sigma) truth_.stream.noise_sigma = *options.noise_sigma;
  if (options.drop_probability) truth_.stream.drop_probability = *options.drop_probability;
  if (options.eye_offset_ms) truth_.stream.eye_offset_ms = *options.eye_offset_ms;
  if (options.jpeg_quality) truth_.stream.jpeg_quality = *options.jpeg_quality;
  if (options.quantum_us)
    for (ServoTruth& s : truth_.servos) s.quantum_us = *options.quantum_us;
  truth_.Validate(options.truth_file.empty() ? "built-in robot truth" : options.truth_file);
  head_ = truth_.HeadModel();
  scene_ =
      options.scene ? *options.scene : (options.scene_file.empty() ? DefaultScene() : LoadScene(options.scene_file));
  for (const SceneTarget& t : scene_.targets)
    textures_.push_back(std::make_unique<TargetTexture>(MakeTargetTexture(t.definition)));
  background_ = MakeBackgroundTexture(scene_.background);
  for (int e = 0; e < 2; ++e) renderers_[e] = std::make_unique<EyeRenderer>(truth_.intrinsics[e], truth_.stream);
  // Power on: every servo at rest at the robot file's centre.
  for (int i = 0; i < kNumServos; ++i) servos_.emplace_back(truth_.servos[i], truth_.robot.servos[i].centre_us, 0);
  last_command_ = truth_.robot.Centre();
  start_ = std::chrono::steady_clock::now();
}

VirtualOwl::~VirtualOwl() = default;

int64_t VirtualOwl::NowLocked() const {
  if (!real_time_) return now_ns_;
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - start_).count();
}

int64_t VirtualOwl::NowNs() {
  std::lock_guard<std::mutex> lock(mutex_);
  return NowLocked();
}

void VirtualOwl::AdvanceTo(int64_t t_ns, std::unique_lock<std::mutex>* lock) {
  if (!real_time_) {
    now_ns_ = std::max(now_ns_, t_ns);
    return;
  }
  const int64_t wait = t_ns - NowLocked();
  if (wait <= 0) return;
  lock->unlock();
  std::this_thread::sleep_for(std::chrono::nanoseconds(wait));
  lock->lock();
}

void VirtualOwl::SleepNs(int64_t ns) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (ns > 0) AdvanceTo(NowLocked() + ns, &lock);
}

robot::ServoReply VirtualOwl::SendServos(const robot::PwmVector& pwm_us) {
  std::unique_lock<std::mutex> lock(mutex_);
  robot::ServoReply reply;
  const int64_t t = NowLocked();
  for (int i = 0; i < kNumServos; ++i) {
    reply.sent[i] = truth_.robot.servos[i].Clamp(pwm_us[i]);
    reply.clamped |= reply.sent[i] != pwm_us[i];
    servos_[i].Command(reply.sent[i], t);
    servos_[i].ForgetBefore(t - kHistoryNs);
  }
  last_command_ = reply.sent;
  reply.ok = true;
  reply.text = "ok";
  if (!real_time_) AdvanceTo(t + int64_t(std::llround(truth_.stream.servo_reply_ms * 1e6)), &lock);
  return reply;
}

int64_t VirtualOwl::ExposureNs(int64_t seq, models::Eye eye) const {
  const int64_t base = int64_t(std::llround(double(seq) * 1e9 / truth_.stream.fps));
  return eye == kRightEye ? base + int64_t(std::llround(truth_.stream.eye_offset_ms * 1e6)) : base;
}

int64_t VirtualOwl::StampNs(int64_t seq) const {
  return ExposureNs(seq, kLeftEye) + int64_t(std::llround(std::max(truth_.stream.latency_ms * 1e6, 0.0) +
                                                          std::max(0.0, truth_.stream.eye_offset_ms) * 1e6));
}

bool VirtualOwl::IsDropped(int64_t seq) const {
  if (truth_.stream.drop_probability <= 0) return false;
  const double u = double(Mix(seed_ * 0x632BE59BD9B4E019ull ^ Mix(uint64_t(seq) + 0x51ED27ull)) >> 11) * 0x1.0p-53;
  return u < truth_.stream.drop_probability;
}

int64_t VirtualOwl::NewestReceivedSeq(int64_t t_ns) const {
  // Largest seq with StampNs(seq) <= t_ns; -1 if none.
  const double period = 1e9 / truth_.stream.fps;
  int64_t k = int64_t(std::floor((t_ns - StampNs(0)) / period));
  k = std::max<int64_t>(k, -1);
  while (StampNs(k + 1) <= t_ns) ++k;
  while (k >= 0 && StampNs(k) > t_ns) --k;
  return k;
}

std::optional<robot::StereoFrame> VirtualOwl::GrabFrame(int64_t after_stamp_ns, int64_t timeout_ns) {
  std::unique_lock<std::mutex> lock(mutex_);
  const int64_t now = NowLocked();
  const int64_t deadline = now + std::max<int64_t>(0, timeout_ns);
  // The newest frame already received, if it is new enough.
  int64_t k = NewestReceivedSeq(now);
  int64_t newest = k;
  while (newest >= 0 && IsDropped(newest)) --newest;
  int64_t chosen = -1;
  if (newest >= 0 && StampNs(newest) > after_stamp_ns) {
    chosen = newest;
  } else {
    // Wait for the next received frame with stamp > after.
    int64_t next = std::max(k + 1, NewestReceivedSeq(after_stamp_ns) + 1);
    next = std::max<int64_t>(next, 0);
    while (IsDropped(next)) ++next;
    if (StampNs(next) > deadline) {
      AdvanceTo(deadline, &lock);
      return std::nullopt;
    }
    AdvanceTo(StampNs(next), &lock);
    chosen = next;
  }
  if (cached_frame_ && cached_frame_->seq == chosen) return cached_frame_;
  const FrameTruth ft = TruthForFrame(chosen);
  const SceneDescription scene = scene_;
  const uint64_t revision = scene_revision_;
  lock.unlock();
  robot::StereoFrame frame = Compose(chosen, ft, scene, revision);
  lock.lock();
  cached_frame_ = frame;
  return frame;
}

models::JointAngles VirtualOwl::JointAnglesAt(int64_t t_ns) const {
  const auto s = ServoAnglesAt(t_ns);
  models::JointAngles a;
  for (int e = 0; e < 2; ++e) {
    a.pan_rad[e] = s[models::kPanServo[e]];
    a.tilt_rad[e] = s[models::kTiltServo[e]];
  }
  a.neck_rad = s[models::kNeck];
  return a;
}

std::array<double, kNumServos> VirtualOwl::ServoAnglesAt(int64_t t_ns) const {
  std::array<double, kNumServos> s{};
  for (int i = 0; i < kNumServos; ++i) s[i] = servos_[i].AngleAt(t_ns);
  return s;
}

std::optional<std::array<models::JointAngles, 2>> VirtualOwl::TruthAnglesForFrame(int64_t seq) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const FrameTruth f = TruthForFrame(seq);
  return std::array<models::JointAngles, 2>{f.angles[0], f.angles[1]};
}

robot::PwmVector VirtualOwl::LastCommand() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return last_command_;
}

models::Rigid3d VirtualOwl::CamFromBase(models::Eye eye, const models::JointAngles& a) const {
  double pose[7];
  head_.geometry.cam_from_eye[eye].ToArray(pose);
  return models::Rigid3d::Map(pose) *
         models::HeadFromEye(head_.geometry.centre_in_head[eye].data(), a.pan_rad[eye], a.tilt_rad[eye]).Inverse() *
         models::HeadFromBase(a.neck_rad);
}

FrameTruth VirtualOwl::TruthForFrame(int64_t seq) const {
  FrameTruth f;
  f.seq = seq;
  f.stamp_ns = StampNs(seq);
  for (int e = 0; e < 2; ++e) {
    const auto eye = models::Eye(e);
    f.exposure_ns[e] = ExposureNs(seq, eye);
    f.angles[e] = JointAnglesAt(f.exposure_ns[e]);
    f.cam_from_base[e] = CamFromBase(eye, f.angles[e]);
  }
  return f;
}

// A camera that moved less than this since an eye's last render shows the same image: 1e-7 rad
// and 1e-8 m move no pixel by more than 1e-4 px at 0.1 m. A settling servo (first-order lag)
// gets there within about 16 lag constants, so a still head renders once, not 30 times a second.
constexpr double kReuseAngle_rad = 1e-7;
constexpr double kReuseShift_m = 1e-8;

cv::Mat VirtualOwl::EyeGrey(models::Eye e,
                            const FrameTruth& ft,
                            const SceneDescription& scene,
                            uint64_t scene_revision) const {
  const bool still = std::none_of(
      scene.targets.begin(), scene.targets.end(), [](const SceneTarget& t) { return t.visible && !t.motion.Still(); });
  const models::Rigid3d& pose = ft.cam_from_base[e];
  if (still) {
    std::lock_guard<std::mutex> lock(rendered_mutex_[e]);
    const RenderedEye& r = rendered_[e];
    if (r.valid && r.scene_revision == scene_revision &&
        r.cam_from_base.rotation.angularDistance(pose.rotation) < kReuseAngle_rad &&
        (r.cam_from_base.translation - pose.translation).norm() < kReuseShift_m)
      return r.grey.clone();
  }
  std::vector<const TargetTexture*> tex;
  for (const auto& t : textures_) tex.push_back(t.get());
  // The socket axis is the head's forward axis: in the camera frame via cam_from_head.
  const models::Rigid3d cam_from_head = pose * models::HeadFromBase(ft.angles[e].neck_rad).Inverse();
  const Eigen::Vector3d axis = cam_from_head.rotation * Eigen::Vector3d::UnitZ();
  // A held target is where it was when each row of this eye was exposed (the eyes expose
  // eye_offset_ms apart; rows rolling_shutter_ms from top to bottom).
  const RowTiming timing{ft.exposure_ns[e], truth_.stream.rolling_shutter_ms * 1e6 / truth_.robot.image_height};
  cv::Mat grey;
  renderers_[e]->Render(pose, axis, truth_.socket, scene, tex, background_, &grey, nullptr, timing);
  ++num_eye_renders_;
  if (still) {
    std::lock_guard<std::mutex> lock(rendered_mutex_[e]);
    rendered_[e] = {true, scene_revision, pose, grey.clone()};
  }
  return grey;
}

robot::StereoFrame VirtualOwl::Compose(int64_t seq,
                                       const FrameTruth& ft,
                                       const SceneDescription& scene,
                                       uint64_t scene_revision) const {
  const int w = truth_.robot.image_width, h = truth_.robot.image_height;
  cv::Mat grey[2];
  // The eyes render independently (each has its own renderer; the scene and textures are
  // read-only here): both at once halves the wall time of every frame on two cores. Noise
  // is a function of (seed, frame, eye) alone, so the frame is the same either way.
  cv::parallel_for_(cv::Range(0, 2), [&](const cv::Range& eyes) {
    for (int e = eyes.start; e < eyes.end; ++e) {
      grey[e] = EyeGrey(models::Eye(e), ft, scene, scene_revision);
      AddSensorNoise(&grey[e], truth_.stream.noise_sigma, seed_, uint64_t(seq) * 2 + e);
    }
  });
  cv::Mat side(h, 2 * w, CV_8UC3);
  const bool swap = truth_.robot.swap_eyes;
  cv::cvtColor(grey[swap ? kRightEye : kLeftEye], side(cv::Rect(0, 0, w, h)), cv::COLOR_GRAY2BGR);
  cv::cvtColor(grey[swap ? kLeftEye : kRightEye], side(cv::Rect(w, 0, w, h)), cv::COLOR_GRAY2BGR);
  if (truth_.robot.mirror_stream) cv::flip(side, side, 1);
  robot::StereoFrame f;
  f.seq = seq;
  f.stamp_ns = ft.stamp_ns;
  cv::Mat received = side;
  if (encode_jpeg_) {
    cv::imencode(".jpg", side, f.jpeg, {cv::IMWRITE_JPEG_QUALITY, truth_.stream.jpeg_quality});
    if (!decode_frames_) return f;
    received = cv::imdecode(f.jpeg, cv::IMREAD_COLOR);
    if (received.empty())
      throw std::runtime_error("virtual Owl: JPEG round trip of frame " + std::to_string(seq) + " failed");
  }
  // What a client does with the stream: undo the configured mirror/swap, split.
  if (truth_.robot.mirror_stream) cv::flip(received, received, 1);
  f.left = received(cv::Rect(swap ? w : 0, 0, w, h)).clone();
  f.right = received(cv::Rect(swap ? 0 : w, 0, w, h)).clone();
  return f;
}

robot::StereoFrame VirtualOwl::RenderFrame(int64_t seq) const {
  std::unique_lock<std::mutex> lock(mutex_);
  const FrameTruth ft = TruthForFrame(seq);
  const SceneDescription scene = scene_;
  const uint64_t revision = scene_revision_;
  lock.unlock();
  return Compose(seq, ft, scene, revision);
}

cv::Mat VirtualOwl::RenderEyeGrey(models::Eye eye, const models::JointAngles& angles, cv::Mat* depth_z_m) const {
  std::unique_lock<std::mutex> lock(mutex_);
  const SceneDescription scene = scene_;
  lock.unlock();
  std::vector<const TargetTexture*> tex;
  for (const auto& t : textures_) tex.push_back(t.get());
  const models::Rigid3d cam_from_base = CamFromBase(eye, angles);
  const models::Rigid3d cam_from_head = cam_from_base * models::HeadFromBase(angles.neck_rad).Inverse();
  cv::Mat grey;
  renderers_[eye]->Render(cam_from_base,
                          cam_from_head.rotation * Eigen::Vector3d::UnitZ(),
                          truth_.socket,
                          scene,
                          tex,
                          background_,
                          &grey,
                          depth_z_m);
  return grey;
}

std::string VirtualOwl::Describe() const {
  std::ostringstream s;
  s << "virtual Owl '" << truth_.name << "' seed " << seed_ << (real_time_ ? " (real time)" : " (virtual clock)");
  return s.str();
}

void VirtualOwl::SetTargetPose(const std::string& name, const Eigen::Isometry3d& base_from_target) {
  std::lock_guard<std::mutex> lock(mutex_);
  SceneTarget* t = scene_.Find(name);
  if (!t) throw std::invalid_argument("virtual Owl: no scene target named '" + name + "'");
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c)
      if (!std::isfinite(base_from_target.matrix()(r, c)))
        throw std::invalid_argument("virtual Owl: pose of '" + name + "' is not finite");
  const Eigen::Vector3d at = base_from_target.translation();
  if (at.cwiseAbs().maxCoeff() > kMaxTargetOffset_m) {
    throw std::invalid_argument("virtual Owl: pose of '" + name + "' at t_m = [" + io::SignificantText(at.x(), 6) +
                                ", " + io::SignificantText(at.y(), 6) + ", " + io::SignificantText(at.z(), 6) +
                                "] is more than " + io::SignificantText(kMaxTargetOffset_m, 6) +
                                " m from the head along an axis");
  }
  t->base_from_target = base_from_target;
  cached_frame_.reset();
  ++scene_revision_;
}

void VirtualOwl::SetTargetMotion(const std::string& name, const TargetMotion& motion) {
  std::lock_guard<std::mutex> lock(mutex_);
  SceneTarget* t = scene_.Find(name);
  if (!t) throw std::invalid_argument("virtual Owl: no scene target named '" + name + "'");
  if (!(motion.speed_m_s >= 0 && motion.speed_m_s < 2 && motion.angular_speed_deg_s >= 0 &&
        motion.angular_speed_deg_s < 360))
    throw std::invalid_argument("virtual Owl: motion of '" + name + "' out of range");
  t->motion = motion;
  cached_frame_.reset();
  ++scene_revision_;
}

void VirtualOwl::SetTargetVisible(const std::string& name, bool visible) {
  std::lock_guard<std::mutex> lock(mutex_);
  SceneTarget* t = scene_.Find(name);
  if (!t) throw std::invalid_argument("virtual Owl: no scene target named '" + name + "'");
  t->visible = visible;
  cached_frame_.reset();
  ++scene_revision_;
}

std::optional<Eigen::Isometry3d> VirtualOwl::TargetPose(const std::string& name) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const SceneTarget* t = scene_.Find(name);
  if (!t) return std::nullopt;
  return t->base_from_target;
}

std::vector<std::string> VirtualOwl::TargetNames() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::string> names;
  for (const SceneTarget& t : scene_.targets) names.push_back(t.name());
  return names;
}

SceneDescription VirtualOwl::SceneState() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return scene_;
}

std::string VirtualOwl::TruthJson() const {
  std::lock_guard<std::mutex> lock(mutex_);
  nlohmann::json j;
  j["robot_truth"] = RobotTruthJson(truth_);
  j["scene"] = SceneJson(scene_);
  j["seed"] = seed_;
  const int64_t now = NowLocked();
  j["now_ns"] = now;
  for (int i = 0; i < kNumServos; ++i) {
    const ServoDynamics& s = servos_[i];
    j["servo_state"][models::kServoNames[i]] = {{"last_command_us", last_command_[i]},
                                                {"accepted_us", s.ActivePulseUs()},
                                                {"approach", s.Approach()},
                                                {"angle_deg", s.AngleAt(now) * 180.0 / M_PI},
                                                {"target_deg", s.TargetRad() * 180.0 / M_PI}};
  }
  return j.dump(2);
}

}  // namespace owlcal::sim
