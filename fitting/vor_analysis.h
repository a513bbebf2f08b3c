#pragma once
// The vestibulo-ocular reflex's numbers from sampled angles and image positions (the vor step's
// vor.csv, protocols/vor_step.h): a sine of known frequency fitted to a joint angle, the VOR gain
// and phase lag from the neck's and the eye's sines, a step's steady-state gain, and the image
// slip of a trial.
//
// Conventions: angles in the head model's convention (gaze = neck + pan), so a perfect VOR has
// pan = -neck and gain 1 (for a target at a finite distance slightly above 1: the eye sits ahead
// of the neck's axis). The gain is |pan| / |neck| of the fitted sines; the phase lag is how far
// the eye's counter-rotation is behind the neck's turn, wrapped to (-180, 180] deg (positive:
// the eye lags), also as a time at the frequency.
//
// Usage:
//   SineFit n = FitSine(t, neck_deg, 0.5), e = FitSine(t, pan_deg, 0.5);
//   VorGain g = GainFromSines(n, e, 0.5);   // g.gain +- g.gain_sigma, g.lag_deg
#include <string>
#include <vector>

namespace owlcal::fitting {

// y(t) = offset + drift t + amplitude sin(2 pi f t + phase), least squares; sigmas from the
// residual scatter (the fit's covariance scaled by the residual variance).
struct SineFit {
  bool ok = false;
  std::string reason;  // why not ok
  int num_samples = 0;
  double amplitude = 0, amplitude_sigma = 0;
  double phase_rad = 0, phase_sigma_rad = 0;
  double offset = 0, drift_per_s = 0;
  double rms_residual = 0;
};
// Needs at least 6 samples spanning half a period; t and y the same length.
SineFit FitSine(const std::vector<double>& t_s, const std::vector<double>& y, double hz);

struct VorGain {
  bool ok = false;
  std::string reason;
  double gain = 0, gain_sigma = 0;
  double lag_deg = 0, lag_sigma_deg = 0;
  double lag_ms = 0, lag_sigma_ms = 0;
};
VorGain GainFromSines(const SineFit& neck, const SineFit& pan, double hz);

// A step profile (0 until lead_s, +A until lead_s + hold_s, 0 after): the steady-state gain
// -(change of pan) / (change of neck) from the means over [0, lead_s) and over the last third
// of the hold; sigma from the scatter in the two windows.
VorGain StepGain(const std::vector<double>& t_s,
                 const std::vector<double>& neck,
                 const std::vector<double>& pan,
                 double lead_s,
                 double hold_s);

// Image slip of one eye over a trial: the target's position relative to its first sample
// (px: RMS and peak of |x - x0|) and its velocity between consecutive samples (px/s from x,
// deg/s from the target's angle in the camera), RMS and peak of the magnitude. Samples not
// found are skipped (a velocity spans only consecutive found samples).
struct SlipStats {
  int num_samples = 0;
  int num_velocities = 0;
  double rms_px = 0, peak_px = 0;
  double rms_px_per_s = 0, peak_px_per_s = 0;
  double rms_deg_per_s = 0, peak_deg_per_s = 0;
};
SlipStats ComputeSlip(const std::vector<double>& t_s,
                      const std::vector<double>& x_px,
                      const std::vector<double>& angle_deg,
                      const std::vector<bool>& found);

}  // namespace owlcal::fitting
