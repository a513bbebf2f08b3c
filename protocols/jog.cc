#include "protocols/jog.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "io/number_text.h"
#include "models/head_kinematics.h"
#include "protocols/fixation.h"
#include "protocols/image_motion.h"
#include "protocols/limits_search.h"
#include "protocols/run_context.h"

namespace owlcal::protocols {
namespace {

constexpr int kDownsample = 4;
constexpr double kMovedFraction = 0.3;  // as the limits protocol's default

const char* EndName(int direction) { return direction > 0 ? "max" : "min"; }

std::string Num(double v, int digits = 1) { return io::FixedText(v, digits); }

}  // namespace

bool JogOptions::Check(std::string* why) const {
  auto bad = [&](const std::string& s) {
    *why = "jog: " + s;
    return false;
  };
  if (step_us < 1 || step_us > 100) return bad("step_us " + std::to_string(step_us) + " is outside 1..100");
  if (widen_step_us < 1 || widen_step_us > 20)
    return bad("widen_step_us " + std::to_string(widen_step_us) + " is outside 1..20 (small steps beyond a limit)");
  if (envelope_min_us < 1000 || envelope_max_us > 2200 || envelope_min_us >= envelope_max_us)
    return bad("envelope " + std::to_string(envelope_min_us) + ".." + std::to_string(envelope_max_us) +
               " us must lie within 1000..2200 us");
  if (settle_ms < 0 || settle_ms > 10000) return bad("settle_ms " + std::to_string(settle_ms) + " is outside 0..10000");
  if (scale_step_us < 5 || scale_step_us > 100)
    return bad("scale_step_us " + std::to_string(scale_step_us) + " is outside 5..100");
  if (!(rim_fraction > 0 && rim_fraction < 1)) return bad("rim_fraction must be in (0, 1)");
  if (max_auto_steps < 1) return bad("max_auto_steps must be at least 1");
  return true;
}

models::RobotConfig MakeJogRobotConfig(const models::RobotConfig& file, const JogOptions& options) {
  models::RobotConfig c = file;
  for (models::ServoConfig& s : c.servos) {
    s.min_us = std::min(s.min_us, options.envelope_min_us);
    s.max_us = std::max(s.max_us, options.envelope_max_us);
  }
  return c;
}

JogSession::JogSession(robot::RobotInterface& robot,
                       const models::RobotConfig& file,
                       const JogOptions& options,
                       std::ostream* log)
    : robot_(robot), file_(file), o_(options), log_(log) {
  std::string why;
  if (!o_.Check(&why)) throw std::invalid_argument(why);
  for (int s = 0; s < models::kNumServos; ++s) {
    const models::ServoConfig& c = file_.servos[s];
    if (c.min_us < o_.envelope_min_us || c.max_us > o_.envelope_max_us)
      throw std::invalid_argument("jog: the robot file's " + c.name + " limits " + std::to_string(c.min_us) + ".." +
                                  std::to_string(c.max_us) + " us lie outside the envelope");
    const models::ServoConfig& r = robot_.Config().servos[s];
    if (r.min_us > o_.envelope_min_us || r.max_us < o_.envelope_max_us)
      throw std::invalid_argument("jog: the robot link clamps " + c.name + " to " + std::to_string(r.min_us) + ".." +
                                  std::to_string(r.max_us) + " us: build it with MakeJogRobotConfig");
    ends_[s][0] = {c.min_us, c.min_us, "file", ""};
    ends_[s][1] = {c.max_us, c.max_us, "file", ""};
  }
  pose_ = file_.Centre();
}

std::string JogSession::Log(const std::string& line) {
  if (log_) *log_ << line << "\n";
  return line;
}

void JogSession::Move(int servo, int pulse) {
  if (pulse < o_.envelope_min_us || pulse > o_.envelope_max_us)
    throw std::logic_error("jog: " + std::string(models::kServoNames[servo]) + " " + std::to_string(pulse) +
                           " us is outside the envelope (never sent)");
  pose_[servo] = pulse;
  robot_.SendServos(pose_);
  sent_.push_back(pose_);
  robot_.SleepNs(int64_t(o_.settle_ms) * 1'000'000);
}

cv::Mat JogSession::EyeImage(int servo) {
  std::optional<robot::StereoFrame> f = robot_.GrabFrame(last_stamp_, 3'000'000'000);
  if (!f) throw std::runtime_error("jog: no frame from " + robot_.Describe() + " within 3 s");
  last_stamp_ = f->stamp_ns;
  return (ServoEye(servo) == models::kLeftEye ? f->left : f->right).clone();
}

std::string JogSession::Start() {
  pose_ = file_.Centre();
  robot_.SendServos(pose_);
  sent_.push_back(pose_);
  robot_.SleepNs(int64_t(std::max(o_.settle_ms, 500)) * 1'000'000);
  std::optional<robot::StereoFrame> f = robot_.GrabFrame(last_stamp_, 3'000'000'000);
  if (!f) throw std::runtime_error("jog: no frame from " + robot_.Describe() + " within 3 s");
  last_stamp_ = f->stamp_ns;
  std::string text = "centre pose sent;";
  for (int e = 0; e < 2; ++e) {
    const cv::Mat& img = e == models::kLeftEye ? f->left : f->right;
    rim0_[e] = RimFraction(img);
    cv::Scalar mean, sd;
    cv::meanStdDev(MotionThumb(img, kDownsample), mean, sd);
    textured_[e] = sd[0] >= o_.min_contrast_grey;
    text += std::string(" ") + models::kEyeNames[e] + " eye " +
            (textured_[e] ? "textured (image checks on)"
                          : "black or constant (grey std " + Num(sd[0]) + "): no image checks, widen by eye only");
  }
  return Log(text);
}

void JogSession::Select(int servo) {
  if (servo < 0 || servo >= models::kNumServos) throw std::invalid_argument("jog: no servo " + std::to_string(servo));
  servo_ = servo;
  anchor_servo_ = -1;
}

std::string JogSession::Step(int direction) {
  const int s = servo_;
  const JogEnd& end = End(s, direction);
  int nv = pose_[s] + direction * o_.step_us;
  const bool beyond = direction > 0 ? nv > end.limit_us : nv < end.limit_us;
  if (beyond) {
    if (pose_[s] == end.limit_us)
      return Log(std::string(models::kServoNames[s]) + " is at its " + EndName(direction) + " limit " +
                 std::to_string(end.limit_us) + " us (" + end.how + "): not moved. Press 'w' to widen it by " +
                 std::to_string(o_.widen_step_us) + " us, 'a' to widen until the images show the end-stop or rim");
    nv = end.limit_us;
  }
  anchor_servo_ = -1;
  Move(s, nv);
  return Log(std::string(models::kServoNames[s]) + " -> " + std::to_string(nv) + " us");
}

std::string JogSession::GoToLimit(int direction) {
  anchor_servo_ = -1;
  Move(servo_, End(servo_, direction).limit_us);
  return Log(std::string(models::kServoNames[servo_]) + " -> its " + EndName(direction) + " limit " +
             std::to_string(pose_[servo_]) + " us");
}

std::string JogSession::Centre() {
  anchor_servo_ = -1;
  pose_ = file_.Centre();
  robot_.SendServos(pose_);
  sent_.push_back(pose_);
  robot_.SleepNs(int64_t(o_.settle_ms) * 1'000'000);
  return Log("centre pose");
}

bool JogSession::RimChecked(int servo) const { return servo != models::kNeck && textured_[ServoEye(servo)]; }

bool JogSession::Anchor(int servo, int direction) {
  const int lim = End(servo, direction).limit_us;
  const int centre = file_.servos[servo].centre_us;
  int inside = lim - direction * o_.scale_step_us;
  if ((inside - centre) * direction < 0) inside = centre;
  // Both images approached from the inside (outward moves only), so backlash and dead band
  // do not shorten the measured step.
  int before = inside - direction * o_.scale_step_us;
  if ((before - centre) * direction < 0) before = centre;
  if (before != inside) Move(servo, before);
  Move(servo, inside);
  const cv::Mat a = MotionThumb(EyeImage(servo), kDownsample);
  Move(servo, lim);
  const cv::Mat at_limit = EyeImage(servo);
  anchor_thumb_ = MotionThumb(at_limit, kDownsample);
  anchor_rim_ = RimFraction(at_limit) - rim0_[ServoEye(servo)];
  anchor_servo_ = servo;
  anchor_dir_ = direction;
  anchor_us_ = lim;
  stop_ = StopDetector(std::max(8.0, 2.0 * o_.widen_step_us), 0.5 * o_.widen_step_us);
  image_check_ = false;
  if (!textured_[ServoEye(servo)] || inside == lim) return false;
  const double focal_px = NominalFocalPx(file_);
  const double nominal = file_.servos[servo].nominal_deg_per_us * M_PI / 180.0 * focal_px;
  const double shift = ThumbShift(a, anchor_thumb_, kDownsample).px[ServoAxis(servo)];
  if (std::abs(shift) < kMovedFraction * nominal * std::abs(lim - inside)) {
    Log("no image motion between " + std::to_string(inside) + " and " + std::to_string(lim) + " us (" +
        Num(std::abs(shift)) + " px): already at a stop? widen by eye only");
    return false;
  }
  scale_ = std::abs(shift) / std::abs(lim - inside);
  sign_ = shift > 0 ? 1.0 : -1.0;  // sign of an outward image shift
  image_check_ = true;
  Log(std::string(models::kServoNames[servo]) + " anchor at " + std::to_string(lim) + " us: image scale " +
      Num(scale_, 3) + " px/us (nominal " + Num(nominal, 3) + ") from " + std::to_string(inside) + " us");
  return true;
}

bool JogSession::WidenOnce(int direction, std::string* what) {
  const int s = servo_;
  JogEnd& end = ends_[s][direction > 0 ? 1 : 0];
  const std::string name = std::string(models::kServoNames[s]) + " " + EndName(direction);
  rim_at_limit_ = false;
  if (anchor_servo_ != s || anchor_dir_ != direction || pose_[s] != end.limit_us) Anchor(s, direction);
  {
    if (RimChecked(s) && anchor_us_ == end.limit_us && anchor_rim_ > o_.rim_fraction) {
      rim_at_limit_ = true;
      last_rim_ = anchor_rim_;
      *what = name + ": the socket rim already shows at the limit " + std::to_string(end.limit_us) + " us (rim +" +
              Num(anchor_rim_, 3) + " over the centre pose): too wide, not widened; 'a' narrows it to where the rim " +
              "goes, or step inward and confirm";
      return true;
    }
  }
  const int nv = std::clamp(end.limit_us + direction * o_.widen_step_us, o_.envelope_min_us, o_.envelope_max_us);
  if (nv == end.limit_us) {
    *what = name + " is at the envelope " + std::to_string(nv) + " us: not widened";
    return true;
  }
  Move(s, nv);
  const cv::Mat img = EyeImage(s);
  last_rim_ = RimFraction(img) - rim0_[ServoEye(s)];
  if (RimChecked(s) && last_rim_ > o_.rim_fraction) {
    end.how = "rim";
    end.message = "rim darkening " + Num(last_rim_, 3) + " at " + std::to_string(nv) + " us";
    Move(s, end.limit_us);
    *what = name + ": the socket rim shows at " + std::to_string(nv) + " us; limit " + std::to_string(end.limit_us) +
            " us (the last pulse without it), servo back there";
    return true;
  }
  if (image_check_) {
    const double shift = ThumbShift(anchor_thumb_, MotionThumb(img, kDownsample), kDownsample).px[ServoAxis(s)];
    last_shift_px_ = std::abs(shift);
    const double travel = sign_ * shift / scale_;
    const double commanded = std::abs(nv - anchor_us_);
    if (stop_.Stopped(commanded, travel)) {
      // The stop: where the image stopped following (limits_search.h), inside the last pulse.
      // One us further inside than the rounding, so measurement noise never puts the limit
      // past the stop.
      const double stop = anchor_us_ + direction * (stop_.StopTravel() - 1.0);
      int at = direction > 0 ? int(std::floor(stop)) : int(std::ceil(stop));
      at = direction > 0 ? std::clamp(at, anchor_us_, nv - 1) : std::clamp(at, nv + 1, anchor_us_);
      end.limit_us = at;
      end.how = "end-stop";
      end.message = "commanded " + Num(commanded) + " us beyond " + std::to_string(anchor_us_) + ", image shows " +
                    Num(travel) + " us";
      Move(s, at);
      anchor_servo_ = -1;
      *what = name + ": the image stopped following at " + std::to_string(nv) + " us (" + end.message +
              "); end-stop limit " + std::to_string(at) + " us, servo back there";
      return true;
    }
    last_travel_ = travel;
  }
  end.limit_us = nv;
  end.how = "widened";
  end.message = image_check_ ? "the image follows: " + Num(last_travel_) + " of " +
                                   std::to_string(std::abs(nv - anchor_us_)) + " us since " + std::to_string(anchor_us_)
                             : "no image check";
  *what = name + " widened to " + std::to_string(nv) + " us (" + end.message + "; press Enter to confirm)";
  return false;
}

std::string JogSession::Widen(int direction) {
  const JogEnd& end = End(servo_, direction);
  if (end.how == "end-stop" || end.how == "rim")
    return Log(std::string(models::kServoNames[servo_]) + " " + EndName(direction) + ": the images showed the " +
               end.how + " at " + std::to_string(end.limit_us) + " us; not widened further");
  std::string what;
  WidenOnce(direction, &what);
  return Log(what);
}

std::string JogSession::WidenAuto(int direction) {
  const JogEnd& end = End(servo_, direction);
  if (end.how == "end-stop" || end.how == "rim") return Widen(direction);
  if (!textured_[ServoEye(servo_)])
    return Log(
        "auto-widening needs the images (this eye is black or constant): widen step by step ('w') and confirm by eye");
  std::string what;
  for (int i = 0; i < o_.max_auto_steps; ++i) {
    if (WidenOnce(direction, &what)) return Log(rim_at_limit_ ? Narrow(direction) : what);
    if (!image_check_) return Log(what + "; auto-widening stopped: the images show no motion to check (widen by eye)");
    Log(what);
  }
  return Log(what + "; auto-widening stopped after " + std::to_string(o_.max_auto_steps) + " steps");
}

std::string JogSession::Narrow(int direction) {
  const int s = servo_;
  JogEnd& end = ends_[s][direction > 0 ? 1 : 0];
  const int centre = file_.servos[s].centre_us;
  const std::string name = std::string(models::kServoNames[s]) + " " + EndName(direction);
  anchor_servo_ = -1;
  for (int p = end.limit_us; p != centre;) {
    p -= direction * o_.widen_step_us;
    if ((p - centre) * direction < 0) p = centre;
    Move(s, p);
    last_rim_ = RimFraction(EyeImage(s)) - rim0_[ServoEye(s)];
    if (last_rim_ <= o_.rim_fraction) {
      const int was = end.limit_us;
      end.limit_us = p;
      end.how = "rim";
      end.message = "the rim shows beyond " + std::to_string(p) + " us (narrowed from " + std::to_string(was) + ")";
      return name + ": the socket rim shows at the limit " + std::to_string(was) + " us; narrowed to " +
             std::to_string(p) + " us, the first pulse inward without it (rim +" + Num(last_rim_, 3) + "), servo there";
    }
  }
  return name + ": the rim darkens the image border even near the centre: no limit from the images (is the scene a " +
         "plain lit wall?); set the limit by eye and confirm";
}

std::string JogSession::Confirm() {
  const int s = servo_;
  const int p = pose_[s];
  const int c = file_.servos[s].centre_us;
  if (p == c) return Log(std::string(models::kServoNames[s]) + " is at its centre: nothing to confirm");
  const int d = p > c ? 1 : -1;
  JogEnd& end = ends_[s][d > 0 ? 1 : 0];
  end.limit_us = p;
  end.how = "confirmed";
  end.message = "confirmed by the person";
  return Log(std::string(models::kServoNames[s]) + " " + EndName(d) + " limit confirmed at " + std::to_string(p) +
             " us");
}

std::string JogSession::StatusLine() const {
  const int s = servo_;
  const JogEnd& lo = End(s, -1);
  const JogEnd& hi = End(s, +1);
  std::string line = std::string(models::kServoNames[s]) + " " + std::to_string(pose_[s]) + " us  [min " +
                     std::to_string(lo.limit_us) + " " + lo.how + " .. max " + std::to_string(hi.limit_us) + " " +
                     hi.how + "]  pose";
  for (int i = 0; i < models::kNumServos; ++i) line.append(" ").append(std::to_string(pose_[i]));
  if (anchor_servo_ == s) line += "  image shift " + Num(last_shift_px_) + " px, rim " + Num(last_rim_, 3);
  return line;
}

models::RobotConfig JogSession::Result(std::vector<std::string>* notes) const {
  models::RobotConfig c = file_;
  for (int s = 0; s < models::kNumServos; ++s)
    for (int d : {-1, 1}) {
      const JogEnd& e = End(s, d);
      if (e.Final()) {
        (d > 0 ? c.servos[s].max_us : c.servos[s].min_us) = e.limit_us;
      } else if (e.how == "widened" && notes) {
        notes->push_back(std::string(models::kServoNames[s]) + " " + EndName(d) + " widened to " +
                         std::to_string(e.limit_us) + " us but not confirmed: the file keeps " +
                         std::to_string(e.file_us) + " us");
      }
    }
  return c;
}

}  // namespace owlcal::protocols
