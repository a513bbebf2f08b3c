#include "protocols/fixation.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/detector.h"
#include "io/number_text.h"
#include "models/head_model.h"

namespace owlcal::protocols {
namespace {

class FixationLocator : public TargetLocator {
 public:
  explicit FixationLocator(const calib::FixationDetectorOptions& o) : options_(o) {}
  bool Prepare(const robot::StereoFrame&, std::string*) override {
    has_last_[0] = has_last_[1] = false;
    found_[0] = found_[1] = false;
    return true;
  }
  std::optional<double> LastRadiusPx(int eye) const override {
    if (!found_[eye]) return std::nullopt;
    return last_radius_[eye];
  }
  // Tracks: near the last position first (a textured background has dark spots that can
  // outscore a small, distant disc), the whole image when it is not there.
  std::optional<Eigen::Vector2d> Locate(const cv::Mat& image, int eye) override {
    const auto p = Find(image, eye);
    found_[eye] = p.has_value();
    return p;
  }
  // Tracks from px next: the blob of the last find's radius (else the size hint) closest to px,
  // or with no radius known the best blob, within the windows around px.
  void Expect(int eye, const Eigen::Vector2d& px) override {
    has_last_[eye] = true;
    last_[eye] = px;
    if (!(last_radius_[eye] > 0)) last_radius_[eye] = std::max(0.0, options_.size_hint_px);
  }
  std::string Name() const override { return "fixation"; }

 private:
  std::optional<Eigen::Vector2d> Find(const cv::Mat& image, int eye) {
    if (has_last_[eye]) {
      // Two windows around the last position; never jump to a far blob once tracking.
      for (int scale : {1, 2}) {
        const int half = scale * std::max(30, int(5 * last_radius_[eye]));
        const cv::Rect roi = cv::Rect(int(last_[eye].x()) - half, int(last_[eye].y()) - half, 2 * half, 2 * half) &
                             cv::Rect(0, 0, image.cols, image.rows);
        if (roi.width <= 8 || roi.height <= 8) continue;
        calib::FixationDetectorOptions o = options_;
        o.border_px = 0;
        o.expected_px = last_[eye] - Eigen::Vector2d(roi.x, roi.y);
        o.expected_radius_px = last_radius_[eye];
        // The disc may shrink to half its last size (it is moved away, or blurs into a smaller
        // thresholded blob while it moves); a far disc found at 3.1 px must not be lost at 2.9.
        if (o.size_hint_px <= 0 && last_radius_[eye] > 0)
          o.min_radius_px = std::min(o.min_radius_px, std::max(1.0, 0.5 * last_radius_[eye]));
        // The disc keeps its contrast; a background spot that a blurred, fast-moving disc
        // leaves alone in the window has far less (the sim's texture: ~0.35 of black-white).
        o.min_contrast = std::max(options_.min_contrast, 0.6 * last_contrast_[eye]);
        const calib::FixationDetection d = calib::DetectFixationTarget(image(roi), o);
        if (d.found) {
          last_[eye] = d.centre + Eigen::Vector2d(roi.x, roi.y);
          last_radius_[eye] = d.radius_px;
          last_contrast_[eye] = d.contrast;
          return last_[eye];
        }
      }
      return std::nullopt;
    }
    const calib::FixationDetection d = calib::DetectFixationTarget(image, options_);
    if (!d.found) return std::nullopt;
    has_last_[eye] = true;
    last_[eye] = d.centre;
    last_radius_[eye] = d.radius_px;
    last_contrast_[eye] = d.contrast;
    return d.centre;
  }

  calib::FixationDetectorOptions options_;
  bool has_last_[2] = {false, false};
  bool found_[2] = {false, false};
  Eigen::Vector2d last_[2];
  double last_radius_[2] = {0, 0};
  double last_contrast_[2] = {0, 0};
};

class TemplateLocator : public TargetLocator {
 public:
  TemplateLocator(int half, double min_score) : half_(half), min_score_(min_score) {}
  bool Prepare(const robot::StereoFrame& frame, std::string* why) override {
    const cv::Mat& img = frame.right;
    if (img.empty()) {
      if (why) *why = "template locator: the first frame has no right image";
      return false;
    }
    templ_ = calib::CutTemplate(img, Eigen::Vector2d((img.cols - 1) / 2.0, (img.rows - 1) / 2.0), half_);
    cv::Scalar mean, sd;
    cv::meanStdDev(templ_, mean, sd);
    if (sd[0] < 5) {
      if (why) *why = "template locator: the right eye's centre has no texture (grey sd " + std::to_string(sd[0]) + ")";
      return false;
    }
    return true;
  }
  std::optional<Eigen::Vector2d> Locate(const cv::Mat& image, int) override {
    if (templ_.empty()) return std::nullopt;
    const calib::TemplateMatch m = calib::MatchTemplateNcc(image, templ_, min_score_);
    if (!m.found) return std::nullopt;
    return m.centre;
  }
  std::string Name() const override { return "template"; }

 private:
  int half_;
  double min_score_;
  cv::Mat templ_;
};

class BoardLocator : public TargetLocator {
 public:
  explicit BoardLocator(const calib::TargetDefinition& t) : target_(t), corners_(t.Corners()) {
    const Eigen::Vector4d e = t.Extent();
    centre_ = cv::Point2d((e[0] + e[1]) / 2, (e[2] + e[3]) / 2);
  }
  std::optional<Eigen::Vector2d> Locate(const cv::Mat& image, int) override {
    calib::DetectorOptions opt;
    opt.fast_check = true;
    const calib::TargetDetection d = calib::DetectTarget(image, target_, opt);
    if (!d.found || d.pixels.size() < 4) return std::nullopt;
    std::vector<cv::Point2d> board, pix;
    for (size_t i = 0; i < d.corner_ids.size(); ++i) {
      auto it = corners_.find(d.corner_ids[i]);
      if (it == corners_.end()) continue;
      board.emplace_back(it->second.x(), it->second.y());
      pix.emplace_back(d.pixels[i].x(), d.pixels[i].y());
    }
    if (board.size() < 4) return std::nullopt;
    const cv::Mat h = cv::findHomography(board, pix);
    if (h.empty()) return std::nullopt;
    std::vector<cv::Point2d> in = {centre_}, out;
    cv::perspectiveTransform(in, out, h);
    return Eigen::Vector2d(out[0].x, out[0].y);
  }
  std::string Name() const override { return "board"; }

 private:
  calib::TargetDefinition target_;
  std::map<int, Eigen::Vector3d> corners_;
  cv::Point2d centre_;
};

class PixelLocator : public TargetLocator {
 public:
  explicit PixelLocator(const std::array<std::optional<Eigen::Vector2d>, 2>& px) : px_(px) {}
  std::optional<Eigen::Vector2d> Locate(const cv::Mat&, int eye) override { return px_[eye]; }
  std::string LastReason(int eye) const override { return px_[eye] ? "" : "no seed pixel in this eye"; }
  std::string Name() const override { return "pixel"; }

 private:
  std::array<std::optional<Eigen::Vector2d>, 2> px_;
};

class LkLocator : public TargetLocator {
 public:
  LkLocator(std::function<std::unique_ptr<TargetLocator>()> make_seed, const calib::LkTrackerOptions& o, bool reacquire)
      : make_seed_(std::move(make_seed)), options_(o), reacquire_(reacquire) {}
  bool Prepare(const robot::StereoFrame& frame, std::string* why) override {
    std::unique_ptr<TargetLocator> seed = make_seed_();
    if (!seed->Prepare(frame, why)) return false;
    seed_name_ = seed->Name();
    for (int e = 0; e < 2; ++e) {
      first_[e] = cv::Mat();
      const cv::Mat& img = e == models::kLeftEye ? frame.left : frame.right;
      if (!Start(*seed, img, e, "")) lost_base_[e] = reason_[e];
    }
    return true;
  }
  std::optional<Eigen::Vector2d> Locate(const cv::Mat& image, int eye) override {
    // The frame the track started on: the seed's position.
    if (tracker_[eye].tracking() && image.data == start_[eye].data) {
      reason_[eye].clear();
      return tracker_[eye].position();
    }
    std::string lost;
    if (tracker_[eye].tracking()) {
      const calib::LkUpdate u = tracker_[eye].Track(image);
      if (u.ok) {
        reason_[eye].clear();
        start_[eye] = cv::Mat();
        return u.px;
      }
      lost = lost_base_[eye] = u.reason;
    } else {
      lost = "lost earlier: " + lost_base_[eye];
    }
    if (reacquire_) {
      std::unique_ptr<TargetLocator> seed = make_seed_();
      robot::StereoFrame alone;
      alone.left = image;
      alone.right = image;
      const bool prepared = seed->Prepare(alone, nullptr);
      if (prepared && expect_[eye]) seed->Expect(eye, *expect_[eye]);
      expect_[eye].reset();
      if (prepared && Start(*seed, image, eye, lost)) return tracker_[eye].position();
      lost += "; not reacquired: " + reason_[eye];
    }
    reason_[eye] = lost;
    return std::nullopt;
  }
  std::string LastReason(int eye) const override { return reason_[eye]; }
  // The seed's radius of the target where the track last (re)started; nullopt while lost.
  std::optional<double> LastRadiusPx(int eye) const override {
    if (!reason_[eye].empty() && reason_[eye].rfind("reacquired", 0) != 0) return std::nullopt;
    return radius_[eye] > 0 ? std::optional<double>(radius_[eye]) : std::nullopt;
  }
  // A lost track's next reacquisition asks the seed there first (a tracking track ignores it).
  void Expect(int eye, const Eigen::Vector2d& px) override {
    if (!tracker_[eye].tracking()) expect_[eye] = px;
  }
  std::string Name() const override { return "lk"; }

 private:
  // Starts eye's track where the seed finds the target; `after` = why the old one was lost.
  bool Start(TargetLocator& seed, const cv::Mat& img, int eye, const std::string& after) {
    if (after.empty()) tracker_[eye] = calib::LkTracker(options_);
    start_[eye] = cv::Mat();
    const std::optional<Eigen::Vector2d> p = img.empty() ? std::nullopt : seed.Locate(img, eye);
    if (!p) {
      const std::string r = seed.LastReason(eye);
      reason_[eye] = "the " + seed_name_ + " seed did not find the target" + (r.empty() ? "" : " (" + r + ")");
      return false;
    }
    // A reacquired target must look like the one the track started on (the seed's whole-image
    // search finds disc-like blobs on a textured wall when the target is out of view).
    if (!after.empty() && !first_[eye].empty()) {
      const double ncc = calib::PatchNcc(first_[eye], first_px_[eye], img, *p, options_.reacquire_window_px);
      if (ncc < options_.min_reacquire_ncc) {
        reason_[eye] = "the " + seed_name_ + " seed found a blob at (" + io::FixedText(p->x(), 1) + ", " +
                       io::FixedText(p->y(), 1) + ") that does not look like the target (NCC " + io::FixedText(ncc, 2) +
                       ")";
        return false;
      }
    }
    if (const std::optional<double> r = seed.LastRadiusPx(eye)) radius_[eye] = *r;
    std::string why;
    const bool resume = !after.empty() && !first_[eye].empty();
    if (!(resume ? tracker_[eye].Resume(img, *p, &why) : tracker_[eye].Start(img, *p, &why))) {
      reason_[eye] = why;
      return false;
    }
    start_[eye] = img;
    if (after.empty()) {
      first_[eye] = img;
      first_px_[eye] = *p;
    }
    reason_[eye] = after.empty() ? "" : "reacquired by the " + seed_name_ + " seed after: " + after;
    return true;
  }

  std::function<std::unique_ptr<TargetLocator>()> make_seed_;
  calib::LkTrackerOptions options_;
  bool reacquire_;
  std::string seed_name_ = "seed";
  calib::LkTracker tracker_[2];
  cv::Mat start_[2];  // the image each track started on (its seed position is the answer there)
  cv::Mat first_[2];  // the image and position of the first start since Prepare (the target's look)
  Eigen::Vector2d first_px_[2];
  std::string reason_[2] = {"not prepared", "not prepared"};
  std::string lost_base_[2] = {"not prepared", "not prepared"};  // why the track was (last) lost
  std::optional<Eigen::Vector2d> expect_[2];                     // Expect's hint for a reacquisition
  double radius_[2] = {0, 0};
};

// Half-cycle peak tracker of one error signal.
struct PeakTracker {
  int sign = 0;
  double peak = 0;
  std::vector<double> peaks;
  void Add(double e, double dead) {
    const int s = e > dead ? 1 : (e < -dead ? -1 : 0);
    if (s == 0) return;
    if (sign != 0 && s != sign) {
      peaks.push_back(peak);
      peak = 0;
    }
    sign = s;
    peak = std::max(peak, std::abs(e));
  }
  // Two consecutive completed half-cycles whose peaks grew (a sustained small limit cycle
  // from backlash is not divergence).
  bool Growing(double floor) const {
    const size_t n = peaks.size();
    if (n < 3) return false;
    return peaks[n - 1] > floor && peaks[n - 1] > 1.05 * peaks[n - 2] && peaks[n - 2] > 1.05 * peaks[n - 3];
  }
};

// A limit cycle across the target on one axis: a servo with a PWM step or dead band
// (models/servo_resolution.h) makes the image jump across the centre between two plateaus and
// cannot put the target closer. Each half-cycle (between two sign changes of the offset, all
// within near_px) gives the plateau on its side: the median |offset| over its frames (the loop
// crawls through the servo's bin for many frames; the few frames of the jump do not count).
struct CrossingTracker {
  int sign = 0;
  int crossings = 0;
  std::vector<double> half;      // |offset| in the current half-cycle
  double plateau[2] = {-1, -1};  // [0] negative side, [1] positive side; -1 unknown
  double min_jump = 0;           // smallest |e_after - e_before| at a crossing
  double last = 0;
  void Add(double e, double near_px) {
    const int s = e > 0 ? 1 : (e < 0 ? -1 : 0);
    if (s == 0) return;
    if (std::abs(e) > near_px) {  // far from the target: no cycle (yet)
      *this = CrossingTracker{};
      return;
    }
    if (sign != 0 && s != sign) {
      std::vector<double> v = half;
      std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
      plateau[sign > 0] = v[v.size() / 2];
      const double jump = std::abs(e - last);
      min_jump = crossings == 0 ? jump : std::min(min_jump, jump);
      ++crossings;
      half.clear();
    }
    half.push_back(std::abs(e));
    sign = s;
    last = e;
  }
  // After a full cycle (both plateaus known), the dead zone takes in the worse plateau (the loop
  // stops on whichever side it is), at least the tolerance.
  double DeadZone(double tolerance_px) const {
    if (crossings < 2 || plateau[0] < 0 || plateau[1] < 0) return tolerance_px;
    return std::max(tolerance_px, 1.05 * std::max(plateau[0], plateau[1]));
  }
};

// Seats a converged command (FixationOptions seat_*, protocols/fixation.h): snaps each controlled
// servo to the seating grid, reaches it with one move of seat_back_us from a known side, waits,
// and measures the residual offsets there. r->outcome becomes kLost when the target is not
// found in a controlled eye at the end.
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
          s.offset_px[e] = *p - Eigen::Vector2d((img.cols - 1) / 2.0, (img.rows - 1) / 2.0);
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

}  // namespace

std::unique_ptr<TargetLocator> MakeFixationLocator(const calib::FixationDetectorOptions& options) {
  return std::make_unique<FixationLocator>(options);
}
std::unique_ptr<TargetLocator> MakeTemplateLocator(int half_size, double min_score) {
  return std::make_unique<TemplateLocator>(half_size, min_score);
}
std::unique_ptr<TargetLocator> MakeBoardLocator(const calib::TargetDefinition& target) {
  return std::make_unique<BoardLocator>(target);
}
std::unique_ptr<TargetLocator> MakeLkLocator(std::function<std::unique_ptr<TargetLocator>()> make_seed,
                                             const calib::LkTrackerOptions& options,
                                             bool reacquire) {
  return std::make_unique<LkLocator>(std::move(make_seed), options, reacquire);
}
std::unique_ptr<TargetLocator> MakePixelLocator(const std::array<std::optional<Eigen::Vector2d>, 2>& px) {
  return std::make_unique<PixelLocator>(px);
}

bool AppearanceCheckOptions::Check(std::string* why) const {
  if (window_px != 0 && (window_px < 5 || window_px % 2 == 0)) {
    if (why) *why = "appearance check: window_px must be 0 (from the target's radius) or odd and >= 5";
    return false;
  }
  if (!(min_ncc > -1 && min_ncc < 1)) {
    if (why) *why = "appearance check: min_ncc must be in (-1, 1)";
    return false;
  }
  return true;
}

AppearanceCheckedLocator::AppearanceCheckedLocator(std::unique_ptr<TargetLocator> inner,
                                                   const AppearanceCheckOptions& options)
    : inner_(std::move(inner)), options_(options) {
  std::string why;
  if (!options_.Check(&why)) throw std::invalid_argument(why);
}

void AppearanceCheckedLocator::ForgetLook() {
  for (int e = 0; e < 2; ++e) {
    look_[e] = templ_[e] = cv::Mat();
    found_[e] = has_last_[e] = false;
    ncc_[e] = NAN;
  }
}

std::optional<Eigen::Vector2d> AppearanceCheckedLocator::Checked(const cv::Mat& image,
                                                                 int eye,
                                                                 const std::optional<Eigen::Vector2d>& p,
                                                                 std::string* why) {
  if (!p) {
    const std::string r = inner_->LastReason(eye);
    *why = "the " + inner_->Name() + " locator found nothing" + (r.empty() ? "" : " (" + r + ")");
    return std::nullopt;
  }
  ncc_[eye] = calib::PatchNcc(look_[eye], look_px_[eye], image, *p, window_px_[eye]);
  if (!(ncc_[eye] >= options_.min_ncc)) {
    *why = "the " + inner_->Name() + " locator's blob at (" + io::FixedText(p->x(), 1) + ", " +
           io::FixedText(p->y(), 1) + ") does not look like the target (NCC " + io::FixedText(ncc_[eye], 2) + " < " +
           io::FixedText(options_.min_ncc, 2) + ")";
    return std::nullopt;
  }
  return p;
}

std::optional<Eigen::Vector2d> AppearanceCheckedLocator::Locate(const cv::Mat& image, int eye) {
  found_[eye] = false;
  reason_[eye].clear();
  ncc_[eye] = NAN;
  std::optional<Eigen::Vector2d> p = inner_->Locate(image, eye);
  if (look_[eye].empty()) {  // the first look
    if (!p) {
      reason_[eye] = inner_->LastReason(eye);
      return std::nullopt;
    }
    cv::Mat g;
    if (image.channels() == 1)
      g = image.clone();
    else
      cv::cvtColor(image, g, cv::COLOR_BGR2GRAY);
    int window = options_.window_px;
    if (window == 0) {
      const std::optional<double> r = inner_->LastRadiusPx(eye);
      window = r && *r > 0 ? std::max(5, 2 * int(std::lround(1.75 * *r - 0.5)) + 1) : 41;
    }
    window_px_[eye] = window;
    const int half = window / 2;
    const Eigen::Vector2d r(std::round(p->x()), std::round(p->y()));
    if (r.x() >= half && r.y() >= half && r.x() < g.cols - half && r.y() < g.rows - half) {
      templ_[eye] = calib::CutTemplate(g, r, half);
      templ_offset_[eye] = *p - r;
    }
    look_[eye] = g;
    look_px_[eye] = last_px_[eye] = *p;
    has_last_[eye] = true;
    ncc_[eye] = 1;
    found_[eye] = true;
    return p;
  }
  std::string why;
  p = Checked(image, eye, p, &why);
  if (p) {
    found_[eye] = has_last_[eye] = true;
    last_px_[eye] = *p;
    return p;
  }
  if (options_.reacquire && !templ_[eye].empty()) {
    // Near the last (or expected) position first: the wall has spots that match a small patch as
    // well as a moving target does; then the whole image.
    std::vector<cv::Rect> areas;
    if (has_last_[eye]) {
      const int reach = 4 * templ_[eye].cols;
      areas.push_back(cv::Rect(int(last_px_[eye].x()) - reach, int(last_px_[eye].y()) - reach, 2 * reach, 2 * reach) &
                      cv::Rect(0, 0, image.cols, image.rows));
    }
    areas.push_back(cv::Rect());
    for (const cv::Rect& area : areas) {
      const calib::TemplateMatch m = calib::MatchTemplateNcc(image, templ_[eye], options_.min_ncc, area);
      const std::string where = area.area() > 0 ? " near its last position" : " in the image";
      if (!m.found) {
        why += "; not found again" + where + " (best NCC " + io::FixedText(m.score, 2) + ")";
        continue;
      }
      inner_->Expect(eye, m.centre + templ_offset_[eye]);
      std::string again;
      p = Checked(image, eye, inner_->Locate(image, eye), &again);
      if (p) {
        found_[eye] = has_last_[eye] = true;
        last_px_[eye] = *p;
        reason_[eye] = "reacquired by NCC " + io::FixedText(m.score, 2) + " after: " + why;
        return p;
      }
      why += "; something like the look (NCC " + io::FixedText(m.score, 2) + ") at (" + io::FixedText(m.centre.x(), 1) +
             ", " + io::FixedText(m.centre.y(), 1) + ")" + where + " but: " + again;
    }
  }
  reason_[eye] = why;
  return std::nullopt;
}

std::unique_ptr<AppearanceCheckedLocator> MakeAppearanceCheckedLocator(std::unique_ptr<TargetLocator> inner,
                                                                       const AppearanceCheckOptions& options) {
  return std::make_unique<AppearanceCheckedLocator>(std::move(inner), options);
}

double NominalFocalPx(const models::RobotConfig& robot) { return 585.0 * robot.image_width / 640.0; }

const char* OutcomeName(FixationResult::Outcome o) {
  switch (o) {
    case FixationResult::Outcome::kConverged:
      return "converged";
    case FixationResult::Outcome::kMaxIterations:
      return "max-iterations";
    case FixationResult::Outcome::kDiverged:
      return "diverged";
    case FixationResult::Outcome::kLimit:
      return "heading-for-limit";
    case FixationResult::Outcome::kLost:
      return "target-lost";
    case FixationResult::Outcome::kNotStarted:
      return "not-started";
  }
  return "?";
}

calib::TrialStatus FixationStatus(const FixationResult& r, const FixationOptions& o, std::string* reason) {
  using Outcome = FixationResult::Outcome;
  reason->clear();
  switch (r.outcome) {
    case Outcome::kConverged:
      for (int e = 0; e < 2; ++e)
        if (o.eyes[e] && !r.found[e]) {
          *reason = std::string("target not found in the ") + models::kEyeNames[e] + " eye at the end";
          return calib::TrialStatus::kLostTarget;
        }
      return calib::TrialStatus::kOk;
    case Outcome::kLost:
      *reason = r.message;
      return calib::TrialStatus::kLostTarget;
    case Outcome::kMaxIterations:
      *reason = r.message;
      return calib::TrialStatus::kNotSettled;
    case Outcome::kDiverged:
      *reason = "diverged: " + r.message;
      return calib::TrialStatus::kNotSettled;
    case Outcome::kLimit:
      *reason = "stopped before a limit: " + r.message;
      return calib::TrialStatus::kNotSettled;
    case Outcome::kNotStarted:
      *reason = "could not start: " + r.message;
      return calib::TrialStatus::kFailed;
  }
  *reason = r.message;
  return calib::TrialStatus::kFailed;
}

bool FixationOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = "fixation options: " + m;
    return false;
  };
  if (!eyes[0] && !eyes[1]) return fail("no eye selected");
  if (!pan && !tilt) return fail("no axis selected");
  if (!(gain > 0 && gain < 5)) return fail("gain " + std::to_string(gain) + " must be in (0, 5)");
  if (max_iterations < 1) return fail("max_iterations " + std::to_string(max_iterations) + " must be >= 1");
  if (!(tolerance_px > 0)) return fail("tolerance_px must be > 0");
  if (latency_frames < 0) return fail("latency_frames must be >= 0");
  if (max_step_us < 1) return fail("max_step_us must be >= 1");
  if (!(focal_px > 0)) return fail("focal_px must be > 0");
  if (seat_grid_us < 0 || seat_back_us < 1 || seat_frames < 1 || seat_average < 1)
    return fail("seat_grid_us must be >= 0 and seat_back_us, seat_frames, seat_average >= 1");
  return true;
}

Eigen::Vector2d OffsetToPulseError(const Eigen::Vector2d& offset_px,
                                   int eye,
                                   const models::RobotConfig& robot,
                                   double focal_px) {
  const models::ServoConfig& pan = robot.servos[models::kPanServo[eye]];
  const models::ServoConfig& tilt = robot.servos[models::kTiltServo[eye]];
  const double pan_deg = std::atan(offset_px.x() / focal_px) * 180.0 / M_PI;
  const double tilt_deg = std::atan(-offset_px.y() / focal_px) * 180.0 / M_PI;
  return Eigen::Vector2d(pan.direction * pan_deg / pan.nominal_deg_per_us,
                         tilt.direction * tilt_deg / tilt.nominal_deg_per_us);
}

FixationResult RunFixation(const FixationOptions& o,
                           const models::RobotConfig& robot,
                           TargetLocator& locator,
                           const FixationIo& io) {
  FixationResult r;
  std::string why;
  if (!o.Check(&why)) {
    r.message = why;
    return r;
  }
  const models::PwmVector start = io.command();
  std::array<double, models::kNumServos> state;
  for (int i = 0; i < models::kNumServos; ++i) state[i] = start[i];
  models::PwmVector sent = start;
  PeakTracker peaks[2][2];
  CrossingTracker crossings[2][2];
  double initial_err[2] = {-1, -1};
  int lost = 0, still = 0, wait = 0;
  std::array<int, models::kNumServos> last_dir{};  // sign of each servo's last command change
  for (int k = 0; k < o.max_iterations; ++k) {
    const robot::StereoFrame frame = io.grab();
    if (k == 0 && !locator.Prepare(frame, &why)) {
      r.outcome = FixationResult::Outcome::kNotStarted;
      r.message = why;
      r.final_pwm_us = sent;
      return r;
    }
    FixationSample s;
    s.k = k;
    s.stamp_ns = frame.stamp_ns;
    s.pwm_us = sent;
    bool all_found = true;
    double eye_err[2] = {0, 0};
    for (int e = 0; e < 2; ++e) {
      if (!o.eyes[e]) continue;
      const cv::Mat img = e == models::kLeftEye ? frame.left : frame.right;
      const auto p = locator.Locate(img, e);
      if (!p) {
        all_found = false;
        continue;
      }
      s.found[e] = true;
      s.offset_px[e] = *p - Eigen::Vector2d((img.cols - 1) / 2.0, (img.rows - 1) / 2.0);
      s.radius_px[e] = locator.LastRadiusPx(e);
      r.found[e] = true;
      r.residual_px[e] = s.offset_px[e];
      r.radius_px[e] = s.radius_px[e];
      const double err =
          std::max(o.pan ? std::abs(s.offset_px[e].x()) : 0.0, o.tilt ? std::abs(s.offset_px[e].y()) : 0.0);
      eye_err[e] = err;
      if (initial_err[e] < 0) initial_err[e] = err;
      peaks[e][0].Add(s.offset_px[e].x(), o.tolerance_px);
      peaks[e][1].Add(s.offset_px[e].y(), o.tolerance_px);
      for (int a = 0; a < 2; ++a) crossings[e][a].Add(s.offset_px[e][a], std::max(3 * o.tolerance_px, 16.0));
    }
    r.trace.push_back(s);
    r.iterations = k + 1;
    if (!all_found) {
      if (++lost >= o.lost_frames) {
        r.outcome = FixationResult::Outcome::kLost;
        r.message = "target not found in " + std::to_string(lost) + " consecutive frames";
        // The locator's own reason (an LK track says why it was lost).
        for (int e = 0; e < 2; ++e)
          if (o.eyes[e] && !s.found[e])
            if (const std::string why_lost = locator.LastReason(e); !why_lost.empty())
              r.message += std::string(" (") + models::kEyeNames[e] + " eye: " + why_lost + ")";
        r.final_pwm_us = sent;
        return r;
      }
      continue;
    }
    lost = 0;
    // Divergence: growing oscillation or error far beyond its start.
    for (int e = 0; e < 2; ++e) {
      if (!o.eyes[e]) continue;
      for (int a = 0; a < 2; ++a) {
        if ((a == 0 && !o.pan) || (a == 1 && !o.tilt)) continue;
        if (peaks[e][a].Growing(3 * o.tolerance_px)) {
          r.outcome = FixationResult::Outcome::kDiverged;
          r.message = std::string(models::kEyeNames[e]) + (a == 0 ? " pan" : " tilt") +
                      ": oscillation does not decay (half-cycle peaks " +
                      std::to_string(peaks[e][a].peaks[peaks[e][a].peaks.size() - 2]) + " -> " +
                      std::to_string(peaks[e][a].peaks.back()) + " px) at gain " + std::to_string(o.gain);
          r.final_pwm_us = sent;
          return r;
        }
      }
      if (initial_err[e] >= 0 && eye_err[e] > 2 * std::max(initial_err[e], 10.0)) {
        r.outcome = FixationResult::Outcome::kDiverged;
        r.message = std::string(models::kEyeNames[e]) + " error grew to " + std::to_string(eye_err[e]) + " px from " +
                    std::to_string(initial_err[e]) + " px at gain " + std::to_string(o.gain);
        r.final_pwm_us = sent;
        return r;
      }
    }
    if (wait > 0) {
      --wait;
      continue;
    }
    // Proportional update.
    models::PwmVector next = sent;
    for (int e = 0; e < 2; ++e) {
      if (!o.eyes[e]) continue;
      const Eigen::Vector2d err_us = OffsetToPulseError(s.offset_px[e], e, robot, o.focal_px);
      const int servos[2] = {models::kPanServo[e], models::kTiltServo[e]};
      for (int a = 0; a < 2; ++a) {
        if ((a == 0 && !o.pan) || (a == 1 && !o.tilt)) continue;
        // Dead zone: an axis already within the tolerance is left alone (with backlash an
        // integrating loop would otherwise chase it in a limit cycle); widened to what the
        // servo can resolve once the target was seen to jump across the centre.
        if (std::abs(s.offset_px[e][a]) <= crossings[e][a].DeadZone(o.tolerance_px)) continue;
        const double step = std::clamp(o.gain * err_us[a], -double(o.max_step_us), double(o.max_step_us));
        state[servos[a]] += step;
        next[servos[a]] = static_cast<int>(std::lround(state[servos[a]]));
      }
    }
    // Heading for a limit: stop before sending.
    for (int i = 0; i < models::kNumServos; ++i) {
      if (next[i] == sent[i]) continue;
      const models::ServoConfig& c = robot.servos[i];
      if (next[i] < c.min_us + o.limit_margin_us || next[i] > c.max_us - o.limit_margin_us) {
        r.outcome = FixationResult::Outcome::kLimit;
        r.message = std::string(models::kServoNames[i]) + " would go to " + std::to_string(next[i]) + " us, within " +
                    std::to_string(o.limit_margin_us) + " us of its limit [" + std::to_string(c.min_us) + ", " +
                    std::to_string(c.max_us) + "]: stopped before sending";
        r.final_pwm_us = sent;
        return r;
      }
    }
    const bool unchanged = next == sent;
    bool within = true;
    for (int e = 0; e < 2; ++e)
      for (int a = 0; a < 2; ++a)
        if (o.eyes[e] && ((a == 0 && o.pan) || (a == 1 && o.tilt)))
          within &= std::abs(s.offset_px[e][a]) <= crossings[e][a].DeadZone(o.tolerance_px);
    if (unchanged && within) {
      if (++still >= o.still_frames && o.stop_when_converged) {
        r.outcome = FixationResult::Outcome::kConverged;
        r.message = "converged in " + std::to_string(k + 1) + " frames";
        for (int e = 0; e < 2; ++e)
          for (int a = 0; a < 2; ++a)
            if (crossings[e][a].DeadZone(o.tolerance_px) > o.tolerance_px)
              r.message += std::string(", ") + models::kEyeNames[e] + (a == 0 ? " pan" : " tilt") + " within " +
                           std::to_string(crossings[e][a].DeadZone(o.tolerance_px)).substr(0, 4) +
                           " px (the target jumps across the centre by " +
                           std::to_string(crossings[e][a].min_jump).substr(0, 4) + " px: PWM step or dead band)";
        r.final_pwm_us = sent;
        if (o.seat_grid_us > 0) SeatCommand(o, robot, locator, io, last_dir, &r);
        return r;
      }
    } else {
      still = 0;
    }
    if (!unchanged) {
      for (int i = 0; i < models::kNumServos; ++i)
        if (next[i] != sent[i]) last_dir[i] = next[i] > sent[i] ? 1 : -1;
      io.send(next);
      sent = io.command();
      wait = o.latency_frames;
    }
  }
  r.final_pwm_us = sent;
  r.outcome = still >= o.still_frames ? FixationResult::Outcome::kConverged : FixationResult::Outcome::kMaxIterations;
  r.message = r.outcome == FixationResult::Outcome::kConverged
                  ? "converged (ran all frames)"
                  : "not converged in " + std::to_string(o.max_iterations) + " frames";
  return r;
}

}  // namespace owlcal::protocols
