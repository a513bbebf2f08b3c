// Stage 2 of the calibration: the head from the servo sweep (pipeline/calibrate_stages.h).
#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Cholesky>

#include <opencv2/core/utility.hpp>

#include "models/head_kinematics.h"
#include "pipeline/calibrate_stages.h"
#include "pipeline/tag_study.h"
#include "protocols/placement_views.h"
#include "reports/table.h"

namespace owlcal::pipeline::stages {
namespace {

void MergeHead(const fitting::HeadFit& h, fitting::CalibrationResult* r) {
  for (const auto& p : h.result.parameters) r->Set(p);
  for (const auto& s : h.result.summaries) r->summaries.push_back(s);
  for (const auto& w : h.result.warnings) r->warnings.push_back(w);
  for (const auto& n : h.result.notes) r->notes.push_back(n);
  r->head = h.head;
  if (h.result.diagnostics.contains("head")) r->diagnostics["head"] = h.result.diagnostics["head"];
  for (auto it = h.result.inputs.begin(); it != h.result.inputs.end(); ++it) r->inputs[it.key()] = it.value();
  if (nlohmann::json c = HeadCovarianceJson(h); !c.is_null()) {
    c["source"] = "head fit";
    r->diagnostics["covariance"] = c;
  }
}

// Sigma of the stereo fit's focal scale: g = mean of log fx, log fy over both eyes, through the
// joint covariance of the two eyes' intrinsics (their errors are correlated: one board in both
// views). 0 when the fit has none.
double FocalScaleSigma(const fitting::StereoFit& f) {
  const int n = int(f.cameras[0].params.size());
  if (n < 2 || int(f.cameras[1].params.size()) != n || f.covariance.rows() < 2 * n) return 0.0;
  std::vector<std::pair<int, double>> a;  // covariance row, d g / d value
  for (int e = 0; e < 2; ++e)
    for (int k = 0; k < 2; ++k)
      if (f.cameras[e].params[k] > 0) a.emplace_back(e * n + k, 0.25 / f.cameras[e].params[k]);
  double var = 0;
  for (const auto& [i, ai] : a)
    for (const auto& [j, aj] : a) var += ai * f.covariance(i, j) * aj;
  return std::isfinite(var) && var > 0 ? std::sqrt(var) : 0.0;
}

// Covariance of one eye's intrinsics (fx fy cx cy dist..., the head's camera block) from the
// stereo fit, times widen^2; nullopt when the fit has none. A parameter the stereo fit did not
// determine (zero row) gets a variance of 1e8 (sigma 1e4 px or 1e4 in a coefficient): no prior.
std::optional<Eigen::MatrixXd> IntrinsicsPriorFromStereo(const fitting::StereoFit& f, int eye, double widen) {
  const int n = int(f.cameras[eye].params.size());
  if (f.covariance.rows() < 2 * n) return std::nullopt;
  Eigen::MatrixXd c = f.covariance.block(eye * n, eye * n, n, n) * (widen * widen);
  bool any = false;
  for (int i = 0; i < n; ++i) {
    if (std::isfinite(c(i, i)) && c(i, i) > 0) {
      any = true;
      continue;
    }
    c.row(i).setZero();
    c.col(i).setZero();
    c(i, i) = 1e8;
  }
  if (!any || !c.allFinite() || Eigen::LLT<Eigen::MatrixXd>(c).info() != Eigen::Success) return std::nullopt;
  return c;
}

// The sweep's board classes: chessboard and tag corners in one fit, each kind whitened by its own
// measured noise, each tag corner compared with where the detector puts it under the lens's
// distortion (fitting/tag_edge_corner.h), and the tags whitened wider for the errors a static sheet
// repeats in every view (CalibratePipelineOptions::tag_sigma_factor).
void AddBoardClasses(const std::string& sweep, double tag_sigma_factor, fitting::HeadFitOptions* ho) {
  for (const auto& [board, cls] : NoiseClassesOfDataset(sweep)) ho->noise_class_of_board.emplace(board, cls);
  for (const auto& [board, size] : TagSizesOfDataset(sweep)) ho->tag_size_of_board.emplace(board, size);
  for (const auto& [board, size] : ho->tag_size_of_board)
    if (const auto it = ho->noise_class_of_board.find(board); it != ho->noise_class_of_board.end())
      ho->sigma_factor_of_class[it->second] = tag_sigma_factor;
}

// The stereo fit's intrinsics as a prior (CalibratePipelineOptions::head_prior_from_stereo): the
// sweep's boards pin the focal lengths, the servo scales and the IPD only together; the stereo
// views pin the focal lengths on their own (docs/uncertainty.md). True when a prior was set.
bool SetPriorFromStereo(const Inputs& in,
                        const std::optional<fitting::StereoFit>& stereo,
                        fitting::HeadFitOptions* ho) {
  if (!in.options.head_prior_from_stereo || !ho->fit_intrinsics || !stereo || !stereo->ok ||
      ho->intrinsics_prior_covariance[0] || ho->intrinsics_prior_covariance[1])
    return false;
  bool set = false;
  for (int e = 0; e < 2; ++e) {
    ho->intrinsics_prior_covariance[e] = IntrinsicsPriorFromStereo(*stereo, e, ho->measured_sigma_factor);
    set |= ho->intrinsics_prior_covariance[e].has_value();
    // ... and its covariance (as fitted) the floor of the head fit's: the sweep's views share the
    // detector's bias with the stereo views (HeadFitOptions::intrinsics_covariance_floor).
    ho->intrinsics_covariance_floor[e] = IntrinsicsPriorFromStereo(*stereo, e, 1.0);
  }
  if (set)
    in.Progress("  intrinsics prior: the stereo fit's covariance x " + reports::Fmt(ho->measured_sigma_factor, 3) +
                "^2");
  return set;
}

// The fit fusing the tags: its intrinsics floor scaled (CalibratePipelineOptions::fused_floor_scale),
// and the focal scale and the principal points no better known than the stereo fit knows them
// (HeadFitOptions::focal_scale_sigma_floor, principal_point_covariance_floor): the static tag
// sheets move them by more than their residuals show (CalibratePipelineOptions::fused_pinhole_floor).
fitting::HeadFitOptions FusedOptions(const CalibratePipelineOptions& o,
                                     const fitting::HeadFitOptions& ho,
                                     const std::optional<fitting::StereoFit>& stereo,
                                     bool prior_from_stereo) {
  fitting::HeadFitOptions fused = ho;
  for (auto& floor : fused.intrinsics_covariance_floor) {
    if (!floor) continue;
    if (o.fused_floor_scale > 0)
      *floor *= o.fused_floor_scale * o.fused_floor_scale;
    else
      floor.reset();
  }
  if (o.fused_pinhole_floor && prior_from_stereo && stereo) {
    fused.focal_scale_sigma_floor = FocalScaleSigma(*stereo);
    for (int e = 0; e < 2; ++e)
      if (const auto f = IntrinsicsPriorFromStereo(*stereo, e, 1.0); f && f->rows() >= 4)
        fused.principal_point_covariance_floor[e] = Eigen::MatrixXd(f->block(2, 2, 2, 2));
  }
  return fused;
}

// The chessboard fit's pan-zero sigma as the fused fit's floor (HeadFitOptions::
// pan_zero_sigma_floor_deg): the tags see the eye centres' depths no better. A sigma of ten
// degrees or more is no floor: the chessboard fit did not determine the pan zero (a lens model
// whose coefficients the data cannot separate); the fused fit keeps its own, and the run says so.
void FloorPanZero(const fitting::HeadFit& chessboard,
                  fitting::HeadFitOptions* fused,
                  fitting::CalibrationResult* result) {
  const nlohmann::json pz =
      chessboard.result.diagnostics.value("head", nlohmann::json::object()).value("pan_zero", nlohmann::json::object());
  if (!chessboard.ok || !pz.contains("sigma_deg") || !pz["sigma_deg"].is_number()) return;
  const double floor_deg = pz["sigma_deg"].get<double>();
  if (std::isfinite(floor_deg) && floor_deg < 10) {
    fused->pan_zero_sigma_floor_deg = floor_deg;
    return;
  }
  result->warnings.push_back("pan zero: the chessboard-only head fit did not determine it (sigma " +
                             reports::Fmt(floor_deg, 3) +
                             " deg), so it does not floor the fused fit's; the pans' absolute angles carry the "
                             "fused fit's own sigma");
}

}  // namespace

HeadStage FitHeadFromSweep(const Inputs& in,
                           const std::optional<fitting::StereoFit>& stereo,
                           evaluation::CalibrationRun* run) {
  using reports::Fmt;
  const CalibratePipelineOptions& o = in.options;
  const models::RobotConfig& config = o.config;
  fitting::CalibrationResult& result = run->result;
  HeadStage hs;
  hs.initial = models::NominalHeadModel(config);
  for (int e = 0; e < 2; ++e)
    if (result.cameras[e]) hs.initial.intrinsics[e] = *result.cameras[e];
  hs.options = o.head;
  const std::string sweep = in.Dataset("servo_sweep");
  if (!sweep.empty()) {
    // One board per placement: the sweep places the same chessboard at five poses (the tag
    // sheets around it stay put: one board each).
    hs.sweep_views = protocols::ReadViewsByPlacement(sweep);
    const auto& views = hs.sweep_views;
    fitting::HeadFitOptions& ho = hs.options;
    AddBoardClasses(sweep, o.tag_sigma_factor, &ho);
    const size_t num_chessboard_views = WithoutTags(views, ho.noise_class_of_board).size();
    in.Progress("head fit: " + std::to_string(views.size()) + " views (" +
                std::to_string(views.size() - num_chessboard_views) + " of tag sheets)");
    for (const auto& v : views) hs.neck_moved |= v.pwm_us[models::kNeck] != config.servos[models::kNeck].centre_us;
    const bool prior_from_stereo = SetPriorFromStereo(in, stereo, &ho);
    // With tag views, the fit on the chessboard alone and the fit fusing the tags. The result is
    // the chessboard's unless fuse_tags (CalibratePipelineOptions); the tag study compares them.
    const bool has_tags = num_chessboard_views < views.size();
    std::vector<fitting::HeadFit> fits(has_tags ? 2 : 1);
    fitting::HeadFitOptions fused_options = FusedOptions(o, ho, stereo, prior_from_stereo);
    auto fit = [&](int k) {
      fits[k] = k == 0 ? fitting::FitHead(WithoutTags(views, ho.noise_class_of_board), config, hs.initial, ho)
                       : fitting::FitHead(views, config, hs.initial, fused_options);
    };
    if (has_tags && o.fused_pan_zero_floor) {
      // The fused fit's pan zero floored by the chessboard's: the fits run one after the other.
      fit(0);
      FloorPanZero(fits[0], &fused_options, &result);
      fit(1);
    } else {
      // Two independent single-threaded fits, run at once.
      cv::parallel_for_(cv::Range(0, int(fits.size())), [&](const cv::Range& r) {
        for (int k = r.start; k < r.end; ++k) fit(k);
      });
    }
    if (has_tags) {
      hs.without_tags = fits[0];
      hs.with_tags = fits[1];
      in.Progress("  with the tags: " + hs.with_tags->message);
    }
    const fitting::HeadFit& h = has_tags && o.fuse_tags ? fits[1] : fits[0];
    if (h.ok) {
      MergeHead(h, &result);
      in.Progress("  RMS " + Fmt(h.result.summaries.empty() ? NAN : h.result.summaries.back().rms_px, 3) + " px, IPD " +
                  Fmt(result.Find("head.ipd_mm") ? result.Find("head.ipd_mm")->value : NAN, 5) + " mm");
    } else {
      result.warnings.push_back("head fit failed: " + h.message);
      in.Progress("  failed: " + h.message);
    }
  }
  if (!result.head) {
    result.head = hs.initial;
    result.warnings.push_back("no head fit: ranging uses the nominal head (configured centres, 0.113 deg/us)");
  }
  return hs;
}

}  // namespace owlcal::pipeline::stages
