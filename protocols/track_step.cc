#include "protocols/track_step.h"

#include <cmath>
#include <limits>
#include <optional>

#include <opencv2/imgproc.hpp>

#include "calib/csv.h"
#include "calib/salience.h"
#include "calib/trial_status.h"
#include "protocols/fixate_step.h"

namespace owlcal::protocols {
namespace {

using models::kNumServos;
using models::PwmVector;

constexpr const char* kTrackFrameColumns =
    "step_index,phase,k,t_s,eye,tracker,pan_cmd_us,tilt_cmd_us,status,found,x_px,y_px,reason,true_x_px,true_y_px,"
    "true_in_view";
constexpr const char* kTrackTrialColumns = "step_index,frames,phases,status,reason";
constexpr const char* kSalienceColumns =
    "step_index,frame_index,rank,x_px,y_px,score,intensity,colour,orientation,object,object_distance_px,"
    "object_radius_px,fix_status,fix_reason,fix_iterations,fix_dx_px,fix_dy_px,fixated_object,fixated_distance_px";
constexpr int kMapStridePx = 4;

std::string Fx(double v, int d) { return std::isfinite(v) ? calib::CsvFixed(v, d) : ""; }

// A scene object as the truth sees it in one eye image.
struct ObjectView {
  std::string name;
  Eigen::Vector2d centre_px = Eigen::Vector2d::Zero();
  double radius_px = 0;              // half the outline's diagonal
  std::vector<cv::Point2f> outline;  // the extent's projected quad (a fixation disc: its card)
  bool Contains(const Eigen::Vector2d& px) const {
    return cv::pointPolygonTest(outline, cv::Point2f(float(px.x()), float(px.y())), false) >= 0;
  }
};

// The truth's view of every scene target whose geometry the protocol defines (its `targets`).
std::vector<ObjectView> TrueObjects(RunContext& run, const Protocol& p, int eye, int64_t seq, const cv::Size& image) {
  std::vector<ObjectView> out;
  robot::SceneControl* sc = run.robot().Scene();
  if (!sc) return out;
  const std::optional<models::HeadModel> head = sc->TruthHead();
  const auto angles = sc->TruthAnglesForFrame(seq);
  if (!head || !angles) return out;
  for (const auto& [name, def] : p.targets) {
    const std::optional<Eigen::Isometry3d> pose = sc->TargetPose(name);
    if (!pose) continue;
    ObjectView v;
    v.name = name;
    auto project = [&](const Eigen::Vector3d& in_target, Eigen::Vector2d* px) {
      return head->Project(models::Eye(eye), (*angles)[eye], *pose * in_target, px);
    };
    {
      const Eigen::Vector4d e = def.Extent();
      bool ok = project(Eigen::Vector3d((e[0] + e[1]) / 2, (e[2] + e[3]) / 2, 0), &v.centre_px);
      for (const auto& [x, y] : {std::pair{e[0], e[2]}, {e[1], e[2]}, {e[1], e[3]}, {e[0], e[3]}}) {
        Eigen::Vector2d q;
        ok = ok && project(Eigen::Vector3d(x, y, 0), &q);
        v.outline.emplace_back(float(q.x()), float(q.y()));
        v.radius_px = std::max(v.radius_px, (q - v.centre_px).norm());
      }
      if (!ok) continue;
    }
    // Only what lies (at least partly) in the image.
    if (v.centre_px.x() < -v.radius_px || v.centre_px.y() < -v.radius_px ||
        v.centre_px.x() > image.width - 1 + v.radius_px || v.centre_px.y() > image.height - 1 + v.radius_px)
      continue;
    out.push_back(v);
  }
  return out;
}

// The object containing px (or the nearest one by its centre) and the distance to its centre.
const ObjectView* ObjectAt(const std::vector<ObjectView>& objects, const Eigen::Vector2d& px, bool* inside) {
  const ObjectView* best = nullptr;
  *inside = false;
  double best_d = std::numeric_limits<double>::infinity();
  for (const ObjectView& o : objects) {
    const bool in = o.Contains(px);
    const double d = (o.centre_px - px).norm();
    if ((in && !*inside) || (in == *inside && d < best_d)) {
      best = &o;
      best_d = d;
      *inside = in;
    }
  }
  return best;
}

std::string OutsideMargin(const RunContext& run, const PwmVector& target, int margin) {
  return models::OutsideMargin(run.config(), target, margin, "stopped before sending");
}

void RestAt(RunContext& run, const PwmVector& pose) {
  run.Send(pose);
  SettleRule rest;
  rest.mode = SettleRule::Mode::kTime;
  rest.time_ms = 400;
  run.Settle(rest);
}

void RunSalience(RunContext& run, const Protocol& p, const TrackStep& s, const PwmVector& start) {
  const std::string step = std::to_string(run.step_index());
  const robot::StereoFrame frame = run.Grab();
  const int64_t frame_index = run.Record(frame);
  calib::SalienceOptions so;
  so.num_candidates = s.salience_candidates;
  const calib::SalienceMap map = calib::ComputeSalience(frame.right, so);
  const int stride = std::max(1, int(std::lround(kMapStridePx / map.scale)));
  for (int y = 0; y < map.map.rows; y += stride)
    for (int x = 0; x < map.map.cols; x += stride)
      run.writer().AppendRow("salience_map.csv",
                             "step_index,x_px,y_px,salience",
                             {step,
                              calib::CsvFixed(x * map.scale, 1),
                              calib::CsvFixed(y * map.scale, 1),
                              calib::CsvFixed(map.map.at<float>(y, x), 4)});
  const cv::Size size(frame.right.cols, frame.right.rows);
  const std::vector<ObjectView> objects = TrueObjects(run, p, models::kRightEye, frame.seq, size);
  int rank = 0;
  for (const calib::SalienceCandidate& c : map.candidates) {
    ++rank;
    run.CheckStop();
    bool inside = false;
    const ObjectView* on = ObjectAt(objects, c.px, &inside);
    // Fixate it with the right eye from the start pose (the scene is the one the map saw).
    if (run.cmd() != start) RestAt(run, start);
    FixationOptions fo;
    fo.eyes[models::kLeftEye] = false;
    fo.gain = s.gain;
    fo.focal_px = NominalFocalPx(run.config());
    fo.limit_margin_us = s.limit_margin_us;
    const Eigen::Vector2d seed = c.px;
    std::unique_ptr<TargetLocator> loc = MakeLkLocator(
        [seed] {
          return MakePixelLocator({std::nullopt, seed});
        },
        {},
        false);
    const FixationResult r = run.Fixate(fo, *loc, false, nullptr);
    std::string reason;
    const calib::TrialStatus status = FixationStatus(r, fo, &reason);
    // What the right eye looks at afterwards (truth).
    std::string fixated;
    double fixated_d = NAN;
    {
      const robot::StereoFrame after = run.Grab();
      const std::vector<ObjectView> now = TrueObjects(run, p, models::kRightEye, after.seq, size);
      const Eigen::Vector2d centre((size.width - 1) / 2.0, (size.height - 1) / 2.0);
      bool in = false;
      if (const ObjectView* o = ObjectAt(now, centre, &in); o && in) {
        fixated = o->name;
        fixated_d = (o->centre_px - centre).norm();
      }
    }
    run.writer().AppendRow("salience.csv",
                           kSalienceColumns,
                           {step,
                            std::to_string(frame_index),
                            std::to_string(rank),
                            calib::CsvFixed(c.px.x(), 2),
                            calib::CsvFixed(c.px.y(), 2),
                            calib::CsvFixed(c.score, 4),
                            calib::CsvFixed(c.intensity, 4),
                            calib::CsvFixed(c.colour, 4),
                            calib::CsvFixed(c.orientation, 4),
                            on && inside ? on->name : "",
                            on ? Fx((on->centre_px - c.px).norm(), 2) : "",
                            on ? Fx(on->radius_px, 2) : "",
                            calib::TrialStatusName(status),
                            reason,
                            std::to_string(r.iterations),
                            r.found[models::kRightEye] ? calib::CsvFixed(r.residual_px[models::kRightEye].x(), 3) : "",
                            r.found[models::kRightEye] ? calib::CsvFixed(r.residual_px[models::kRightEye].y(), 3) : "",
                            fixated,
                            Fx(fixated_d, 2)});
    const std::string msg = "salience candidate " + std::to_string(rank) + " at (" + FixedText(c.px.x(), 1) + ", " +
                            FixedText(c.px.y(), 1) + ") score " + FixedText(c.score, 3) +
                            (on && inside ? " on " + on->name : std::string(objects.empty() ? "" : " on no object")) +
                            ": fixation " + calib::TrialStatusName(status) +
                            (reason.empty() ? "" : " (" + reason + ")");
    run.Event("track", msg);
    if (run.options().progress) *run.options().progress << "  " << msg << "\n";
  }
  RestAt(run, start);
}

struct TrackerState {
  std::unique_ptr<TargetLocator> loc;
};

void RunTracking(RunContext& run, const Protocol& p, const TrackStep& s, const PwmVector& start) {
  const std::string step = std::to_string(run.step_index());
  TrackerState trackers[2];
  // The disc detector checked against the disc's first look (it found wall blobs and the image's
  // darker corners while the disc was out of view, and reported them as the target).
  trackers[0].loc = MakeAppearanceCheckedLocator(MakeStepLocator(run, p, Locator::kFixation));
  trackers[1].loc = MakeStepLocator(run, p, Locator::kLk);
  robot::SceneControl* sc = run.robot().Scene();
  std::optional<models::HeadModel> truth_head;
  std::optional<Eigen::Vector3d> target_in_base;
  if (sc) {
    truth_head = sc->TruthHead();
    if (const auto pose = sc->TargetPose(p.target)) target_in_base = pose->translation();
  }
  const double figure_s = s.cycles / s.frequency_hz;
  const double leave_end_s = s.leave_deg > 0 ? figure_s + s.leave_ms / 1000.0 : figure_s;
  const double end_s = s.leave_deg > 0 ? leave_end_s + s.return_ms / 1000.0 : figure_s;
  std::string stopped;
  int frames = 0;
  int64_t t0 = 0;
  for (int k = 0;; ++k) {
    run.CheckStop();
    robot::StereoFrame frame;
    std::string phase = "figure8";
    if (k == 0) {
      frame = run.Grab();
      t0 = run.robot().NowNs();
      for (TrackerState& t : trackers) {
        std::string why;
        if (!t.loc->Prepare(frame, &why)) run.Event("track", t.loc->Name() + " could not start: " + why);
      }
    } else {
      const double t = (run.robot().NowNs() - t0) * 1e-9;
      if (t >= end_s) break;
      double pan_deg = 0, tilt_deg = 0;
      if (t < figure_s) {
        pan_deg = s.pan_deg * std::sin(2 * M_PI * s.frequency_hz * t);
        tilt_deg = s.tilt_deg * std::sin(4 * M_PI * s.frequency_hz * t);
      } else if (t < leave_end_s) {
        phase = "leave";
        pan_deg = s.leave_deg;
      } else {
        phase = "return";
      }
      PwmVector cmd = start;
      for (int e = 0; e < 2; ++e) {
        const models::ServoConfig& pan = run.config().servos[models::kPanServo[e]];
        const models::ServoConfig& tilt = run.config().servos[models::kTiltServo[e]];
        cmd[models::kPanServo[e]] += int(std::lround(pan.direction * pan_deg / pan.nominal_deg_per_us));
        cmd[models::kTiltServo[e]] += int(std::lround(tilt.direction * tilt_deg / tilt.nominal_deg_per_us));
      }
      if (stopped = OutsideMargin(run, cmd, s.limit_margin_us); !stopped.empty()) break;
      run.Send(cmd);
      frame = run.Grab();
    }
    ++frames;
    const double t_s = (frame.stamp_ns - t0) * 1e-9;
    std::optional<std::array<models::JointAngles, 2>> angles;
    if (sc) angles = sc->TruthAnglesForFrame(frame.seq);
    for (int e = 0; e < 2; ++e) {
      const cv::Mat& img = e == models::kLeftEye ? frame.left : frame.right;
      std::optional<Eigen::Vector2d> truth;
      if (truth_head && target_in_base && angles) {
        Eigen::Vector2d tp;
        if (truth_head->Project(models::Eye(e), (*angles)[e], *target_in_base, &tp)) truth = tp;
      }
      const bool in_view =
          truth && truth->x() >= 0 && truth->y() >= 0 && truth->x() <= img.cols - 1 && truth->y() <= img.rows - 1;
      for (TrackerState& t : trackers) {
        std::optional<Eigen::Vector2d> px = t.loc->Locate(img, e);
        std::string reason = t.loc->LastReason(e);
        std::string status = px ? "ok" : "lost";
        if (px && !reason.empty()) {
          status = "reacquired";
        }
        run.writer().AppendRow("track.csv",
                               kTrackFrameColumns,
                               {step,
                                phase,
                                std::to_string(k),
                                calib::CsvFixed(t_s, 6),
                                models::kEyeNames[e],
                                t.loc->Name(),
                                std::to_string(run.cmd()[models::kPanServo[e]]),
                                std::to_string(run.cmd()[models::kTiltServo[e]]),
                                status,
                                px ? "1" : "0",
                                px ? calib::CsvFixed(px->x(), 3) : "",
                                px ? calib::CsvFixed(px->y(), 3) : "",
                                reason,
                                truth ? calib::CsvFixed(truth->x(), 3) : "",
                                truth ? calib::CsvFixed(truth->y(), 3) : "",
                                truth ? (in_view ? "1" : "0") : ""});
      }
    }
  }
  const std::string phases = s.leave_deg > 0 ? "figure8 leave return" : "figure8";
  const calib::TrialStatus status = stopped.empty() ? calib::TrialStatus::kOk : calib::TrialStatus::kNotSettled;
  run.writer().AppendRow("track_trials.csv",
                         kTrackTrialColumns,
                         {step,
                          std::to_string(frames),
                          phases,
                          calib::TrialStatusName(status),
                          stopped.empty() ? "" : "stopped after " + std::to_string(frames) + " frames: " + stopped});
  run.Event("track",
            "tracking: " + std::to_string(frames) + " frames, " + calib::TrialStatusName(status) +
                (stopped.empty() ? "" : " (" + stopped + ")"));
  if (run.options().progress)
    *run.options().progress << "  track: " << frames << " frames (" << phases << "), " << calib::TrialStatusName(status)
                            << (stopped.empty() ? "" : " (" + stopped + ")") << "\n";
  RestAt(run, start);
}

}  // namespace

void RunTrackStep(RunContext& run, const Protocol& p, const TrackStep& s) {
  const PwmVector start = run.cmd();
  if (s.salience_candidates > 0) RunSalience(run, p, s, start);
  RunTracking(run, p, s, start);
}

}  // namespace owlcal::protocols
