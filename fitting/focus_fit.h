#pragma once
// The fixed-focus lens's depth of field, fitted to edge blur measured against distance (the
// lens-sharpness experiment; the blur per image comes from calib/edge_sharpness.h).
//
// Model (thin lens, Gaussian blurs adding in quadrature):
//   sigma(d)^2 = s0^2 + k^2 (1/d - x_f)^2
//   s0   the blur in focus [px]: everything that is not defocus (optics, demosaicing, JPEG);
//   k    the defocus blur per dioptre [px/D]: aperture * fx / 4 for an entrance pupil of
//        diameter `aperture` (a uniform blur disc of diameter c has sigma c / 4);
//   x_f  the focus in dioptres (1 / focus distance; 0 = focused at infinity, < 0 = beyond).
// Fit: weighted least squares on sigma (weights 1 / se^2, se floored at `min_se_px`), global
// over a grid of x_f (for each, s0^2 and k^2 are linear), then Gauss-Newton on (s0, k, x_f);
// the covariance is (J^T W J)^-1, scaled by chi^2 / dof when that exceeds 1 (the scatter the
// data show, not only the per-image standard errors).
//
// Depth of field at a stated threshold: the distances where the blur is at most
// `dof_blur_ratio` x s0 (default sqrt 2: the defocus blur at most the in-focus blur, i.e. the
// sharpness within 1 / sqrt 2 = 71 % of its best):
//   |1/d - x_f| <= h = s0 sqrt(ratio^2 - 1) / k,  near = 1 / (x_f + h),  far = 1 / (x_f - h)
//   (infinity when x_f <= h). Standard deviations by the delta method.
// When the data do not show defocus (k < 2 sigma_k), the focus is undetermined: `focus_found`
// is false, the focus is not reported, and the depth of field is the whole measured range.
//
// Usage:
//   std::vector<fitting::FocusSample> s = {{0.3, 0.52, 0.02}, {0.5, 0.31, 0.01}, ...};
//   fitting::FocusFit f = fitting::FitFocus(s);
//   if (f.ok && f.focus_found) std::cout << f.focus_m << " m\n";
#include <limits>
#include <string>
#include <vector>

namespace owlcal::fitting {

struct FocusSample {
  double distance_m = 0;
  double sigma_px = 0;  // measured edge blur
  double se_px = 0;     // its standard error
};

struct FocusFitOptions {
  double dof_blur_ratio = 1.4142135623730951;  // depth of field: blur <= ratio x s0
  // Floor of a distance's standard error: the blur measured at one placement repeats to
  // ~0.003 px, but moves by ~0.02-0.03 px between neighbouring placements (the target's scale
  // against the pixel grid and the JPEG blocks; on the virtual Owl also its mip levels).
  double min_se_px = 0.02;
  bool Check(std::string* why) const;
};

struct FocusFit {
  bool ok = false;
  std::string reason;  // why not ok
  int num_samples = 0;
  double min_distance_m = 0, max_distance_m = 0;  // the measured range
  double s0_px = 0, s0_sigma_px = 0;
  double k_px_per_dioptre = 0, k_sigma = 0;
  double focus_dioptre = 0, focus_dioptre_sigma = 0;
  bool focus_found = false;                                  // k > 2 sigma_k: the data show defocus
  double focus_m = std::numeric_limits<double>::infinity();  // 1 / x_f (inf when x_f <= 0)
  double focus_sigma_m = 0;
  double dof_near_m = 0, dof_near_sigma_m = 0;
  double dof_far_m = std::numeric_limits<double>::infinity(), dof_far_sigma_m = 0;
  double dof_blur_ratio = 0;  // the threshold used
  double chi2_per_dof = 0;
  double cov[3][3] = {};                    // of (s0, k, x_f), scaled
  double Predict(double distance_m) const;  // sigma(d) [px]
};

FocusFit FitFocus(const std::vector<FocusSample>& samples, const FocusFitOptions& options = {});

// The model's depth of field for known parameters (the truth on the virtual Owl): near and far
// limits [m] where sqrt(s0^2 + k^2 (1/d - x_f)^2) <= ratio * s0 (far = infinity if unbounded).
void DepthOfField(
    double s0_px, double k_px_per_dioptre, double focus_dioptre, double ratio, double* near_m, double* far_m);

}  // namespace owlcal::fitting
