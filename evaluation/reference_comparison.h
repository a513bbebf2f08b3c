#pragma once
// A stereo fit against a reference calibration made elsewhere from the same images (the course's
// stereo_calib intrinsics.xml / extrinsics.xml), with the difference split into three parts that
// add up to it exactly, so that a student can say how much of it the lens model explains:
//
//   detection = B - A   OpenCV's cv::stereoCalibrate with the reference's flags (its lens model,
//                       its constraints, its initial guess) on owlcal's detected corners, minus
//                       the reference: what the corner finder changes;
//   model     = D - B   the same solver and corners with owlcal's chosen lens model (opencv5:
//                       k1 k2 p1 p2 k3, fx and fy free per eye; opencv8: the rational model),
//                       minus the reference's model: what the lens-model choice changes;
//   estimator = E - D   owlcal's fit of a flat board minus OpenCV's with the same model: the
//                       robust loss, the per-eye noise weighting and the solver;
//   bow       = C - E   owlcal's fit minus the same fit with a flat board: what modelling the
//                       board's bow changes (0 when owlcal fitted the board flat).
//
// Per parameter (fx fy cx cy per eye, |T| and T, the rotation vector of R) the total C - A is
// also given in owlcal's sigma. The shares are sigma-weighted projections on the total,
//   share_part = sum_i part_i total_i / sigma_i^2  /  sum_i total_i^2 / sigma_i^2,
// and sum to 1 (a part can be negative: it moved the result towards the reference).
//
// The reference's flags default to the course program's (kit2020-chessboard/README.md):
// CALIB_FIX_ASPECT_RATIO | CALIB_ZERO_TANGENT_DIST | CALIB_USE_INTRINSIC_GUESS |
// CALIB_SAME_FOCAL_LENGTH | CALIB_RATIONAL_MODEL | CALIB_FIX_K3 | CALIB_FIX_K4 | CALIB_FIX_K5,
// initial cameras from cv::initCameraMatrix2D.
//
// Usage:
//   const auto ref = fitting::ReadOpenCvSplitFiles("reference/intrinsics.xml", "reference/extrinsics.xml");
//   const auto cmp = evaluation::CompareWithReference(left_views, right_views, fit, ref, {});
//   std::cout << evaluation::ReferenceComparisonMarkdown(cmp);
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/observation.h"
#include "fitting/opencv_calib_file.h"
#include "fitting/stereo_fit.h"

namespace owlcal::evaluation {

struct ReferenceComparisonOptions {
  int reference_flags = -1;  // cv::CALIB_* of the reference's run; -1 = the course program's
  std::string reference_name = "course stereo_calib";
  std::string reference_model = "rational, k1 k2 k6 free, no tangential, one focal length";
};

struct ReferenceComparisonRow {
  std::string name, unit;
  double reference = 0;                 // A
  double opencv_reference_model = 0;    // B
  double opencv_owlcal_model = 0;       // D
  double owlcal_flat = 0;               // E (= C when owlcal fitted the board flat)
  double owlcal = 0, owlcal_sigma = 0;  // C and its sigma (NaN when not determined)
  double Total() const { return owlcal - reference; }
  double Detection() const { return opencv_reference_model - reference; }
  double Model() const { return opencv_owlcal_model - opencv_reference_model; }
  double Estimator() const { return owlcal_flat - opencv_owlcal_model; }
  double Bow() const { return owlcal - owlcal_flat; }
};

struct ReferenceComparison {
  bool ok = false;
  std::string message;  // why not, or the one-line summary
  std::string reference_name, reference_model, owlcal_model, length_unit;
  int num_pairs = 0;
  double rms_reference_model_px = 0;  // cv::stereoCalibrate's RMS (B)
  double rms_owlcal_model_px = 0;     // (D)
  double rms_owlcal_flat_px = 0;      // (E)
  double rms_owlcal_px = 0;           // owlcal's joint RMS (C)
  bool bowed = false;                 // owlcal fitted the board's bow (then E is a separate fit)
  std::vector<ReferenceComparisonRow> rows;
  double share_detection = 0, share_model = 0, share_estimator = 0, share_bow = 0;  // sum to 1
  double chi2_total = 0;  // sum_i (total_i / sigma_i)^2 over the rows with a sigma
  int num_weighted = 0;
  std::vector<std::string> notes;
};

// left_views/right_views: as for FitStereo (pairs: the same frame_index in both eyes); fit: owlcal's
// stereo fit of them; flat_fit: the same fit with a flat board when `fit` bowed it (nullptr when
// fit is flat; a bowed fit without it puts the bow into the estimator part). The reference's lengths are converted to
// the fit's unit when they differ (mm <-> m); when they cannot be (a target in squares), the translation rows are left
// out and a note says so. Never throws for data: ok = false with the reason.
ReferenceComparison CompareWithReference(const std::vector<calib::View>& left_views,
                                         const std::vector<calib::View>& right_views,
                                         const fitting::StereoFit& fit,
                                         const fitting::StereoFit* flat_fit,
                                         const fitting::OpenCvStereoCalibration& reference,
                                         const ReferenceComparisonOptions& options);

nlohmann::json ReferenceComparisonToJson(const ReferenceComparison& c);
std::string ReferenceComparisonMarkdown(const ReferenceComparison& c);

}  // namespace owlcal::evaluation
