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

LimitSearchResult SearchLimit(int centre_us,
                              int limit_us,
                              int axis,
                              double nominal_px_per_us,
                              const LimitSearchOptions& o,
                              const LimitSearchIo& io) {
  std::string why;
  if (!o.Check(&why)) throw std::invalid_argument(why);
  if (!(nominal_px_per_us > 0)) throw std::invalid_argument("SearchLimit: nominal_px_per_us must be > 0");
  LimitSearchResult r;
  r.measured_us = centre_us;
  const int d = limit_us >= centre_us ? 1 : -1;
  auto fail = [&](const std::string& m) {
    r.status = calib::TrialStatus::kFailed;
    r.cause.clear();
    r.message = m;
    r.measured_us = centre_us;
    r.met_us = centre_us;
    return r;
  };
  if (limit_us == centre_us) {
    r.cause = "configured";
    r.message = "the configured limit is the centre";
    r.met_us = r.measured_us;
    return r;
  }
  // Watches an image until it stops moving (0.); the image unchanged without io.settle.
  auto watch = [&](const cv::Mat& img, bool reference, bool* still_at_once) -> cv::Mat {
    if (!io.settle) {
      if (still_at_once) *still_at_once = true;
      return img;
    }
    const SettledImage s = io.settle(img, reference);
    ++r.watched;
    if (!s.settled) ++r.unsettled;
    if (still_at_once) *still_at_once = s.still_at_first_look;
    return s.image.empty() ? img : s.image;
  };

  // 1) The centre image must show texture. The centre is approached from the other end's side,
  // so the first outward step is not spent taking up backlash.
  if (o.approach_us > 0) io.move(centre_us - d * o.approach_us);
  io.move(centre_us);
  bool still_at_once = true;
  const cv::Mat centre_img = watch(io.image(), true, &still_at_once);
  // A servo still moving at the first look after the wait is watched at every probe.
  r.slow = o.judge_speed ? !still_at_once : o.watch_every_probe;
  const bool watch_each = o.watch_every_probe || r.slow;
  const double rim0 = RimFraction(centre_img);
  const cv::Mat centre_thumb = MotionThumb(centre_img, kSearchDownsample);
  cv::Mat prev = centre_thumb;
  {
    cv::Scalar mean, sd;
    cv::meanStdDev(prev, mean, sd);
    if (sd[0] < o.min_contrast_grey)
      return fail("the image at the centre is black or constant (grey mean " + SearchNum(mean[0]) + ", std " +
                  SearchNum(sd[0]) + " < " + SearchNum(o.min_contrast_grey) +
                  "): covered lens, dead or disconnected camera; no limit measured");
  }
  cv::Mat last_img;  // the last probe's image
  bool last_watched = false;
  auto look = [&](const cv::Mat& img, cv::Mat* thumb) {
    last_img = img;
    *thumb = MotionThumb(img, kSearchDownsample);
    r.rim = RimFraction(img) - rim0;
  };
  // A probe; reference: an image later probes are measured against (watched more strictly).
  auto take = [&](int pulse, cv::Mat* thumb, bool reference) {
    io.move(pulse);
    ++r.probes;
    last_watched = watch_each;
    look(last_watched ? watch(io.image(), reference, nullptr) : io.image(), thumb);
  };
  // Before acting on an unwatched probe (a fast servo's): watch it until still. False when it
  // was watched already.
  auto rewatch = [&](cv::Mat* thumb) {
    if (last_watched || !io.settle) return false;
    last_watched = true;
    look(watch(last_img, false, nullptr), thumb);
    return true;
  };
  auto rim_in = [&] { return o.check_rim && r.rim > o.rim_fraction; };

  // 2) Coarse walk.
  int v = centre_us;
  double shift_sum = 0;
  std::vector<double> step_scales;
  std::vector<std::string> first_tries;  // the first step's probes that did not move enough
  int retry_to = 0;                      // the next first-step probe, longer (0: none)
  while (v != limit_us) {
    int nv = d > 0 ? std::min(limit_us, v + o.coarse_us) : std::max(limit_us, v - o.coarse_us);
    if (retry_to) nv = retry_to, retry_to = 0;
    cv::Mat cur;
    take(nv, &cur, false);
    const double expected = std::abs(nv - v) * nominal_px_per_us;
    double signed_shift = ThumbShift(prev, cur, kSearchDownsample).px[axis];
    if ((rim_in() || std::abs(signed_shift) < o.moved_fraction * expected) && rewatch(&cur))
      signed_shift = ThumbShift(prev, cur, kSearchDownsample).px[axis];
    r.last_shift_px = std::abs(signed_shift);
    if (rim_in()) break;  // the fine walk finds where
    if (r.last_shift_px < o.moved_fraction * expected) {
      if (v == centre_us) {
        // The first step: retried as one longer step from the centre (the servo carries on
        // outward) before the camera or the servo is called frozen.
        const int tries = std::max(1, o.first_step_tries);
        const int span = std::abs(nv - centre_us);
        if (span < tries * o.coarse_us && nv != limit_us) {
          first_tries.push_back(std::to_string(nv) + " us: " + SearchNum(r.last_shift_px) + " px of " +
                                SearchNum(expected));
          const int longer = d > 0 ? std::min(limit_us, centre_us + span + o.coarse_us)
                                   : std::max(limit_us, centre_us - span - o.coarse_us);
          retry_to = longer;  // onwards from here, compared with the centre image: backlash stays taken up
          continue;
        }
        first_tries.push_back(std::to_string(nv) + " us: " + SearchNum(r.last_shift_px) + " px of " +
                              SearchNum(expected));
        std::string tried;
        for (const auto& t : first_tries) tried += (tried.empty() ? "" : ", ") + t;
        return fail("no image motion at the first step from the centre " + std::to_string(centre_us) + " us (" + tried +
                    " expected): frozen or covered camera, or a servo that does not move; no limit measured");
      }
      break;
    }
    shift_sum += signed_shift;
    step_scales.push_back(r.last_shift_px / std::abs(nv - v));
    v = nv;
    prev = cur;
  }
  // The median per-step scale: a last step that ran partly into a stop does not bias it.
  const double scale = step_scales.empty() ? nominal_px_per_us : Median(step_scales);
  const double sign = shift_sum * d < 0 ? -1.0 : 1.0;
  r.px_per_us = scale;
  r.image_px_per_us = step_scales.empty() ? 0.0 : sign * scale;

  // 3) Fine walk from an anchor one coarse step inside the last good pulse, approached from
  // the inside (backlash taken up).
  int anchor = v - d * o.coarse_us;
  if ((anchor - centre_us) * d < 0) anchor = centre_us;
  int inside = anchor - d * o.coarse_us;
  if ((inside - centre_us) * d < 0) inside = centre_us;
  io.move(inside);
  cv::Mat anchor_thumb;
  take(anchor, &anchor_thumb, true);

  // 5) The centre again, now from outside: the backlash band's width against the centre's image
  // from inside (far from a stop, which would cut the band short). An end-stop is then given at
  // approach 0. Called once the fine walk has its answer.
  auto finish = [&]() -> LimitSearchResult {
    r.met_us = r.measured_us;
    double band = o.known_backlash_us;
    const int outside =
        d > 0 ? std::min(limit_us, centre_us + o.coarse_us) : std::max(limit_us, centre_us - o.coarse_us);
    if (o.measure_backlash && outside != centre_us) {
      const double rim = r.rim;
      io.move(outside);
      cv::Mat back;
      take(centre_us, &back, true);
      r.rim = rim;  // the rim of the probe that ended the walk, not of the centre
      band = sign * d * ThumbShift(centre_thumb, back, kSearchDownsample).px[axis] / scale;
      r.backlash_us = band;
    }
    if (r.cause == "end-stop" && band > 0) {
      const double stop = r.met_us - d * 0.5 * band;
      r.measured_us = d > 0 ? int(std::floor(stop)) : int(std::ceil(stop));
      r.message += "; backlash band " + SearchNum(band) + " us: met from inside at " + std::to_string(r.met_us) +
                   " us, at approach 0 " + std::to_string(r.measured_us) + " us";
    }
    return r;
  };

  // In outward us from the anchor command: x = commanded travel, a(x) = applied. Each probe
  // measures travel = a(x) - a(0); deficit = x - travel = (x - a(x)) + a(0). Over the probes
  // that moved, the median deficit (bias) estimates a(0): the PWM step's rounding averages out.
  const double tol = std::max(8.0, 2.0 * o.fine_us);
  StopDetector detector(tol, 0.5 * o.fine_us);
  int last_free = anchor;
  bool retrying = false;  // the previous probe looked like a stop: this one decides
  std::string first_stop;
  r.cause.clear();
  for (int nv = anchor; nv != limit_us;) {
    nv = d > 0 ? std::min(limit_us, nv + o.fine_us) : std::max(limit_us, nv - o.fine_us);
    // The configured limit is approached with one coarse jump from inside: a fine step smaller
    // than the dead band may be ignored, leaving the servo short of the limit as if at a stop.
    if (nv == limit_us) io.move(limit_us - d * o.coarse_us);
    cv::Mat cur;
    take(nv, &cur, false);
    const double commanded = std::abs(nv - anchor);
    const double shift = ThumbShift(anchor_thumb, cur, kSearchDownsample).px[axis];
    const double travel = sign * d * shift / scale;
    r.last_shift_px = std::abs(shift);
    if (rim_in()) {
      r.cause = "rim";
      r.measured_us = last_free;
      r.message = "rim darkening " + SearchNum(r.rim) + " at " + std::to_string(nv) + " us";
      return finish();
    }
    if (detector.Stopped(commanded, travel)) {
      const std::string at = "at " + std::to_string(nv) + " us commanded travel " + SearchNum(commanded) +
                             " us, measured " + SearchNum(travel) + " us from " + std::to_string(anchor) + " us";
      if (!retrying && nv != limit_us) {
        // One fine step further before the stop is believed: a pulse the dead band swallowed
        // leaves the servo where it was, and the next one is taken.
        retrying = true;
        first_stop = at;
        continue;
      }
      const double stop = anchor + d * detector.StopTravel();
      r.cause = "end-stop";
      r.measured_us = d > 0 ? int(std::floor(stop)) : int(std::ceil(stop));
      r.message = "the image stopped following: " + (first_stop.empty() ? at : first_stop + ", " + at) +
                  " (tolerance " + SearchNum(tol) + " us, scale " + SearchNum(scale) + " px/us)";
      return finish();
    }
    if (retrying) ++r.retries;  // the image followed again: the dead band, not a stop
    retrying = false;
    first_stop.clear();
    last_free = nv;
    if (nv == limit_us) {
      // 4) The configured limit reached with the image following, unless the servo applied
      // noticeably less than the limit (a stop just inside it).
      const double reached = travel + detector.bias();  // a(x_limit) - anchor, outward
      const double short_us = commanded - reached;
      if (short_us > 4.0) {
        const double stop = anchor + d * reached;
        r.cause = "end-stop";
        r.measured_us = d > 0 ? int(std::floor(stop)) : int(std::ceil(stop));
        r.message =
            "at the configured limit the servo applied " + SearchNum(short_us) + " us less: a stop just inside it";
      } else {
        r.cause = "configured";
        r.measured_us = limit_us;
        r.message = "configured limit reached with the image following (within " + SearchNum(short_us) + " us)";
      }
      return finish();
    }
  }
  r.cause = "configured";  // the anchor is the limit
  r.measured_us = limit_us;
  r.message = "configured limit reached";
  return finish();
}

}  // namespace owlcal::protocols
