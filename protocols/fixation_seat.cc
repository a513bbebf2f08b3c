#include "protocols/fixation_seat.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include "models/head_model.h"

namespace owlcal::protocols {

void SeatCommand(const FixationOptions& o,
                 const models::RobotConfig& robot,
                 TargetLocator& locator,
                 const FixationIo& io,
                 const std::array<int, models::kNumServos>& approach,
                 FixationResult* r) {
  const models::PwmVector sent = r->final_pwm_us;
  models::PwmVector target = sent;
  std::vector<int> seat;  // the controlled servos
  for (int e = 0; e < 2; ++e) {
    if (!o.eyes[e]) continue;
    if (o.pan) seat.push_back(models::kPanServo[e]);
    if (o.tilt) seat.push_back(models::kTiltServo[e]);
  }
  // The grid pulse nearest to u inside the limits' margin; nullopt when there is none.
  auto grid = [&](int i, double u) -> std::optional<int> {
    const models::ServoConfig& c = robot.servos[i];
    const int lo = c.min_us + o.limit_margin_us, hi = c.max_us - o.limit_margin_us;
    int g = int(std::lround(u / o.seat_grid_us)) * o.seat_grid_us;
    if (g < lo) g += o.seat_grid_us;
    if (g > hi) g -= o.seat_grid_us;
    if (g < lo || g > hi) return std::nullopt;
    return g;
  };
  bool any = false;
  for (int i : seat)
    if (const auto g = grid(i, sent[i])) {
      target[i] = *g;
      any = true;
    }
  if (!any) return;
  auto grab = [&](int n, std::vector<FixationSample>* kept) {
    for (int k = 0; k < n; ++k) {
      const robot::StereoFrame frame = io.grab();
      FixationSample s;
      s.k = r->iterations++;
      s.stamp_ns = frame.stamp_ns;
      s.pwm_us = io.command();
      for (int e = 0; e < 2; ++e) {
        if (!o.eyes[e]) continue;
        const cv::Mat img = e == models::kLeftEye ? frame.left : frame.right;
        if (const auto p = locator.Locate(img, e)) {
          s.found[e] = true;
          s.offset_px[e] = *p - ImageCentre(img);
          s.radius_px[e] = locator.LastRadiusPx(e);
        }
      }
      r->trace.push_back(s);
      if (kept) kept->push_back(s);
    }
  };
  // Each servo approaches its grid pulse from the side the loop came from (same backlash as the
  // loop's, so the image moves by the snap only); below when unknown, above near the lower limit.
  auto seat_at = [&](const models::PwmVector& at, std::vector<FixationSample>* after) {
    models::PwmVector pre = at;
    for (int i : seat) {
      const models::ServoConfig& c = robot.servos[i];
      const int side = approach[i] < 0 ? 1 : -1;
      pre[i] = at[i] + side * o.seat_back_us;
      if (pre[i] < c.min_us || pre[i] > c.max_us) pre[i] = at[i] - side * o.seat_back_us;
    }
    io.send(pre);
    grab(2, nullptr);
    io.send(at);
    after->clear();
    grab(std::max(o.seat_frames, o.seat_average), after);
  };
  std::vector<FixationSample> after;
  seat_at(target, &after);
  // One correction: an axis whose seated offset is more than half a grid step away moves by
  // whole grid steps (the offset converted with the nominal scale) and is seated again.
  {
    models::PwmVector again = target;
    for (int e = 0; e < 2; ++e) {
      if (!o.eyes[e] || !after.back().found[e]) continue;
      const Eigen::Vector2d err_us = OffsetToPulseError(after.back().offset_px[e], e, robot, o.focal_px);
      const int servos[2] = {models::kPanServo[e], models::kTiltServo[e]};
      for (int a = 0; a < 2; ++a) {
        if ((a == 0 && !o.pan) || (a == 1 && !o.tilt) || std::abs(err_us[a]) <= 0.5 * o.seat_grid_us) continue;
        if (const auto g = grid(servos[a], target[servos[a]] + err_us[a])) again[servos[a]] = *g;
      }
    }
    if (again != target) {
      target = again;
      seat_at(target, &after);
    }
  }
  r->final_pwm_us = io.command();
  r->seated = true;
  const int n = std::max(1, o.seat_average);
  // The residual: the mean offset over the last n frames that found the target (a single missed
  // detection is noise); lost when none of them found it.
  for (int e = 0; e < 2; ++e) {
    if (!o.eyes[e]) continue;
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    int m = 0, m_radius = 0;
    double sum_radius = 0;
    for (size_t k = after.size() - std::min(after.size(), size_t(n)); k < after.size(); ++k)
      if (after[k].found[e]) {
        sum += after[k].offset_px[e];
        ++m;
        if (after[k].radius_px[e]) {
          sum_radius += *after[k].radius_px[e];
          ++m_radius;
        }
      }
    r->radius_px[e] = m_radius > 0 ? std::optional<double>(sum_radius / m_radius) : std::nullopt;
    r->found[e] = m > 0;
    if (m == 0) {
      r->outcome = FixationResult::Outcome::kLost;
      r->message = std::string("target not found in the ") + models::kEyeNames[e] + " eye in the last " +
                   std::to_string(n) + " frames after seating the command at " + std::to_string(r->final_pwm_us[0]) +
                   " " + std::to_string(r->final_pwm_us[1]) + " " + std::to_string(r->final_pwm_us[2]) + " " +
                   std::to_string(r->final_pwm_us[3]) + " us (Rx Ry Lx Ly)";
      continue;
    }
    r->residual_px[e] = sum / m;
  }
  if (r->outcome == FixationResult::Outcome::kConverged)
    r->message += ", seated on a " + std::to_string(o.seat_grid_us) + " us grid with a " +
                  std::to_string(o.seat_back_us) + " us approach";
}

}  // namespace owlcal::protocols
