#include "protocols/limits_search.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "io/number_text.h"
#include "models/statistics.h"
#include "protocols/image_motion.h"

namespace owlcal::protocols {
namespace {

constexpr int kSearchDownsample = 2;

std::string SearchNum(double v, int prec = 3) { return io::SignificantText(v, prec); }

using models::Median;

}  // namespace

bool StopDetector::Stopped(double commanded_us, double travel_us) {
  const double deficit = commanded_us - travel_us;
  travel_max_ = std::max(travel_max_, travel_us);
  if (deficit - bias_ > tolerance_us_) return true;
  if (travel_us - prev_travel_ >= moved_us_) {
    moved_deficits_.push_back(deficit);
    bias_ = std::clamp(Median(moved_deficits_), -5.0, 5.0);
  }
  prev_travel_ = travel_us;
  return false;
}

bool LimitSearchOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = "limit search options: " + m;
    return false;
  };
  if (coarse_us < 1) return fail("coarse_us must be >= 1");
  if (fine_us < 1 || fine_us > coarse_us) return fail("fine_us must be in [1, coarse_us]");
  if (!(moved_fraction > 0 && moved_fraction < 1)) return fail("moved_fraction must be in (0, 1)");
  if (!(rim_fraction > 0)) return fail("rim_fraction must be > 0");
  if (!(min_contrast_grey >= 0)) return fail("min_contrast_grey must be >= 0");
  if (first_step_tries < 1 || first_step_tries > 10) return fail("first_step_tries must be in [1, 10]");
  if (approach_us < 0) return fail("approach_us must be >= 0");
  return true;
}

namespace {

// Step 2's outcome: where the coarse walk ended and the image scale it measured.
struct CoarseWalkEnd {
  int last_good_us = 0;        // the last coarse pulse the image followed (the centre: none)
  double scale_px_per_us = 0;  // median image shift per us over the steps that moved (nominal: none)
  double sign = 1;             // +1 or -1: the image shift's sign per outward us along the axis, times d
  bool moved = false;          // a coarse step moved the image
};

// One search of SearchLimit: its steps (limits_search.h 0-5) as methods sharing the probes' state.
class LimitSearcher {
 public:
  LimitSearcher(int centre_us,
                int limit_us,
                int axis,
                double nominal_px_per_us,
                const LimitSearchOptions& o,
                const LimitSearchIo& io)
      : centre_us_(centre_us),
        limit_us_(limit_us),
        axis_(axis),
        nominal_px_per_us_(nominal_px_per_us),
        d_(limit_us >= centre_us ? 1 : -1),
        o_(o),
        io_(io) {
    r_.measured_us = centre_us;
  }

  LimitSearchResult Run() {
    if (limit_us_ == centre_us_) {
      r_.cause = "configured";
      r_.message = "the configured limit is the centre";
      r_.met_us = r_.measured_us;
      return r_;
    }
    if (const auto why = LookAtCentre()) return Fail(*why);
    std::string why;
    const std::optional<CoarseWalkEnd> coarse = WalkCoarse(&why);
    if (!coarse) return Fail(why);
    r_.px_per_us = coarse->scale_px_per_us;
    r_.image_px_per_us = coarse->moved ? coarse->sign * coarse->scale_px_per_us : 0.0;
    WalkFine(*coarse);
    MeasureBacklash(*coarse);
    return r_;
  }

 private:
  LimitSearchResult Fail(const std::string& m) {
    r_.status = calib::TrialStatus::kFailed;
    r_.cause.clear();
    r_.message = m;
    r_.measured_us = centre_us_;
    r_.met_us = centre_us_;
    return r_;
  }

  // 0) Watches an image until it stops moving; the image unchanged without io.settle.
  cv::Mat Watch(const cv::Mat& img, bool reference, bool* still_at_once) {
    if (!io_.settle) {
      if (still_at_once) *still_at_once = true;
      return img;
    }
    const SettledImage s = io_.settle(img, reference);
    ++r_.watched;
    if (!s.settled) ++r_.unsettled;
    if (still_at_once) *still_at_once = s.still_at_first_look;
    return s.image.empty() ? img : s.image;
  }

  void Look(const cv::Mat& img, cv::Mat* thumb) {
    last_img_ = img;
    *thumb = MotionThumb(img, kSearchDownsample);
    r_.rim = RimFraction(img) - rim0_;
  }

  // A probe; reference: an image later probes are measured against (watched more strictly).
  void Take(int pulse, cv::Mat* thumb, bool reference) {
    io_.move(pulse);
    ++r_.probes;
    last_watched_ = watch_each_;
    Look(last_watched_ ? Watch(io_.image(), reference, nullptr) : io_.image(), thumb);
  }

  // Before acting on an unwatched probe (a fast servo's): watch it until still. False when it
  // was watched already.
  bool Rewatch(cv::Mat* thumb) {
    if (last_watched_ || !io_.settle) return false;
    last_watched_ = true;
    Look(Watch(last_img_, false, nullptr), thumb);
    return true;
  }

  bool RimIn() const { return o_.check_rim && r_.rim > o_.rim_fraction; }

  // The outward pulse `step_us` beyond v, clamped to the configured limit.
  int Outward(int v, int step_us) const {
    return d_ > 0 ? std::min(limit_us_, v + step_us) : std::max(limit_us_, v - step_us);
  }

  // 1) The centre image must show texture. The centre is approached from the other end's side,
  // so the first outward step is not spent taking up backlash. Returns why it failed.
  std::optional<std::string> LookAtCentre() {
    if (o_.approach_us > 0) io_.move(centre_us_ - d_ * o_.approach_us);
    io_.move(centre_us_);
    bool still_at_once = true;
    const cv::Mat centre_img = Watch(io_.image(), true, &still_at_once);
    // A servo still moving at the first look after the wait is watched at every probe.
    r_.slow = o_.judge_speed ? !still_at_once : o_.watch_every_probe;
    watch_each_ = o_.watch_every_probe || r_.slow;
    rim0_ = RimFraction(centre_img);
    centre_thumb_ = MotionThumb(centre_img, kSearchDownsample);
    cv::Scalar mean, sd;
    cv::meanStdDev(centre_thumb_, mean, sd);
    if (sd[0] < o_.min_contrast_grey)
      return "the image at the centre is black or constant (grey mean " + SearchNum(mean[0]) + ", std " +
             SearchNum(sd[0]) + " < " + SearchNum(o_.min_contrast_grey) +
             "): covered lens, dead or disconnected camera; no limit measured";
    return std::nullopt;
  }

  // 2) Coarse walk; nullopt (and why) when even the first step from the centre did not move.
  std::optional<CoarseWalkEnd> WalkCoarse(std::string* why) {
    cv::Mat prev = centre_thumb_;
    int v = centre_us_;
    double shift_sum = 0;
    std::vector<double> step_scales;
    std::vector<std::string> first_tries;  // the first step's probes that did not move enough
    int retry_to = 0;                      // the next first-step probe, longer (0: none)
    while (v != limit_us_) {
      int nv = Outward(v, o_.coarse_us);
      if (retry_to) nv = retry_to, retry_to = 0;
      cv::Mat cur;
      Take(nv, &cur, false);
      const double expected = std::abs(nv - v) * nominal_px_per_us_;
      double signed_shift = ThumbShift(prev, cur, kSearchDownsample).px[axis_];
      if ((RimIn() || std::abs(signed_shift) < o_.moved_fraction * expected) && Rewatch(&cur))
        signed_shift = ThumbShift(prev, cur, kSearchDownsample).px[axis_];
      r_.last_shift_px = std::abs(signed_shift);
      if (RimIn()) break;  // the fine walk finds where
      if (r_.last_shift_px < o_.moved_fraction * expected) {
        if (v != centre_us_) break;
        // The first step: retried as one longer step from the centre (the servo carries on
        // outward) before the camera or the servo is called frozen.
        const int span = std::abs(nv - centre_us_);
        first_tries.push_back(std::to_string(nv) + " us: " + SearchNum(r_.last_shift_px) + " px of " +
                              SearchNum(expected));
        if (span < std::max(1, o_.first_step_tries) * o_.coarse_us && nv != limit_us_) {
          retry_to = Outward(centre_us_, span + o_.coarse_us);  // onwards, against the centre image
          continue;
        }
        std::string tried;
        for (const auto& t : first_tries) tried += (tried.empty() ? "" : ", ") + t;
        *why = "no image motion at the first step from the centre " + std::to_string(centre_us_) + " us (" + tried +
               " expected): frozen or covered camera, or a servo that does not move; no limit measured";
        return std::nullopt;
      }
      shift_sum += signed_shift;
      step_scales.push_back(r_.last_shift_px / std::abs(nv - v));
      v = nv;
      prev = cur;
    }
    // The median per-step scale: a last step that ran partly into a stop does not bias it.
    CoarseWalkEnd end;
    end.last_good_us = v;
    end.scale_px_per_us = step_scales.empty() ? nominal_px_per_us_ : Median(step_scales);
    end.sign = shift_sum * d_ < 0 ? -1.0 : 1.0;
    end.moved = !step_scales.empty();
    return end;
  }

  // The end found at `stop` [us, fractional], rounded inward.
  int Inward(double stop) const { return d_ > 0 ? int(std::floor(stop)) : int(std::ceil(stop)); }

  // 3) and 4): the fine walk from an anchor one coarse step inside the last good pulse,
  // approached from the inside (backlash taken up); sets r_.cause, measured_us and message.
  void WalkFine(const CoarseWalkEnd& coarse) {
    int anchor = coarse.last_good_us - d_ * o_.coarse_us;
    if ((anchor - centre_us_) * d_ < 0) anchor = centre_us_;
    int inside = anchor - d_ * o_.coarse_us;
    if ((inside - centre_us_) * d_ < 0) inside = centre_us_;
    io_.move(inside);
    cv::Mat anchor_thumb;
    Take(anchor, &anchor_thumb, true);
    // In outward us from the anchor command: x = commanded travel, a(x) = applied. Each probe
    // measures travel = a(x) - a(0); deficit = x - travel = (x - a(x)) + a(0). Over the probes
    // that moved, the median deficit (bias) estimates a(0): the PWM step's rounding averages out.
    const double tol = std::max(8.0, 2.0 * o_.fine_us);
    StopDetector detector(tol, 0.5 * o_.fine_us);
    int last_free = anchor;
    bool retrying = false;  // the previous probe looked like a stop: this one decides
    std::string first_stop;
    r_.cause.clear();
    for (int nv = anchor; nv != limit_us_;) {
      nv = Outward(nv, o_.fine_us);
      // The configured limit is approached with one coarse jump from inside: a fine step smaller
      // than the dead band may be ignored, leaving the servo short of the limit as if at a stop.
      if (nv == limit_us_) io_.move(limit_us_ - d_ * o_.coarse_us);
      cv::Mat cur;
      Take(nv, &cur, false);
      const double commanded = std::abs(nv - anchor);
      const double shift = ThumbShift(anchor_thumb, cur, kSearchDownsample).px[axis_];
      const double travel = coarse.sign * d_ * shift / coarse.scale_px_per_us;
      r_.last_shift_px = std::abs(shift);
      if (RimIn()) {
        r_.cause = "rim";
        r_.measured_us = last_free;
        r_.message = "rim darkening " + SearchNum(r_.rim) + " at " + std::to_string(nv) + " us";
        return;
      }
      if (detector.Stopped(commanded, travel)) {
        const std::string at = "at " + std::to_string(nv) + " us commanded travel " + SearchNum(commanded) +
                               " us, measured " + SearchNum(travel) + " us from " + std::to_string(anchor) + " us";
        if (!retrying && nv != limit_us_) {
          // One fine step further before the stop is believed: a pulse the dead band swallowed
          // leaves the servo where it was, and the next one is taken.
          retrying = true;
          first_stop = at;
          continue;
        }
        r_.cause = "end-stop";
        r_.measured_us = Inward(anchor + d_ * detector.StopTravel());
        r_.message = "the image stopped following: " + (first_stop.empty() ? at : first_stop + ", " + at) +
                     " (tolerance " + SearchNum(tol) + " us, scale " + SearchNum(coarse.scale_px_per_us) + " px/us)";
        return;
      }
      if (retrying) ++r_.retries;  // the image followed again: the dead band, not a stop
      retrying = false;
      first_stop.clear();
      last_free = nv;
      if (nv == limit_us_) {
        AtConfiguredLimit(anchor, commanded, travel + detector.bias());
        return;
      }
    }
    r_.cause = "configured";  // the anchor is the limit
    r_.measured_us = limit_us_;
    r_.message = "configured limit reached";
  }

  // 4) The configured limit reached with the image following, unless the servo applied
  // noticeably less than the limit (a stop just inside it). reached: a(x_limit) - anchor, outward [us].
  void AtConfiguredLimit(int anchor, double commanded, double reached) {
    const double short_us = commanded - reached;
    if (short_us > 4.0) {
      r_.cause = "end-stop";
      r_.measured_us = Inward(anchor + d_ * reached);
      r_.message =
          "at the configured limit the servo applied " + SearchNum(short_us) + " us less: a stop just inside it";
    } else {
      r_.cause = "configured";
      r_.measured_us = limit_us_;
      r_.message = "configured limit reached with the image following (within " + SearchNum(short_us) + " us)";
    }
  }

  // 5) The centre again, now from outside: the backlash band's width against the centre's image
  // from inside (far from a stop, which would cut the band short). An end-stop is then given at
  // approach 0.
  void MeasureBacklash(const CoarseWalkEnd& coarse) {
    r_.met_us = r_.measured_us;
    double band = o_.known_backlash_us;
    const int outside = Outward(centre_us_, o_.coarse_us);
    if (o_.measure_backlash && outside != centre_us_) {
      const double rim = r_.rim;
      io_.move(outside);
      cv::Mat back;
      Take(centre_us_, &back, true);
      r_.rim = rim;  // the rim of the probe that ended the walk, not of the centre
      band = coarse.sign * d_ * ThumbShift(centre_thumb_, back, kSearchDownsample).px[axis_] / coarse.scale_px_per_us;
      r_.backlash_us = band;
    }
    if (r_.cause == "end-stop" && band > 0) {
      r_.measured_us = Inward(r_.met_us - d_ * 0.5 * band);
      r_.message += "; backlash band " + SearchNum(band) + " us: met from inside at " + std::to_string(r_.met_us) +
                    " us, at approach 0 " + std::to_string(r_.measured_us) + " us";
    }
  }

  const int centre_us_, limit_us_, axis_;
  const double nominal_px_per_us_;
  const int d_;  // +1: the limit is above the centre; -1: below
  const LimitSearchOptions& o_;
  const LimitSearchIo& io_;
  LimitSearchResult r_;
  bool watch_each_ = false;    // every probe watched until still (a slow servo)
  double rim0_ = 0;            // the centre pose's rim darkening
  cv::Mat centre_thumb_;       // the centre's motion thumbnail, approached from inside
  cv::Mat last_img_;           // the last probe's image
  bool last_watched_ = false;  // the last probe was watched until still
};

}  // namespace

LimitSearchResult SearchLimit(int centre_us,
                              int limit_us,
                              int axis,
                              double nominal_px_per_us,
                              const LimitSearchOptions& o,
                              const LimitSearchIo& io) {
  std::string why;
  if (!o.Check(&why)) throw std::invalid_argument(why);
  if (!(nominal_px_per_us > 0)) throw std::invalid_argument("SearchLimit: nominal_px_per_us must be > 0");
  return LimitSearcher(centre_us, limit_us, axis, nominal_px_per_us, o, io).Run();
}

}  // namespace owlcal::protocols
