#pragma once
// The saccade main sequence of a servo from frame-sampled saccades (protocols/main_sequence_step.h).
//
// Model (the servo's linear slew with a first-order lag, models/slew_lag.h): a saccade of size a
// [deg] commanded at t = 0 from rest at theta0 moves the joint as
//   theta(t) = theta0 + d * Y(t - D; a, slew, lag),   d = +-1,
//   Y(tau) = 0 (tau <= 0); slew (tau - lag) + slew lag exp(-tau / lag) while the reference ramps
//   (tau <= a / slew); then a + (Y(a / slew) - a) exp(-(tau - a / slew) / lag),
// where t is a frame's arrival time from the command and D the delay from the command to the
// frame that shows it (the stream latency, the exposure's place in the frame, the servo's dead
// time: one constant for all saccades of one target row). At 30 fps a 40 deg saccade lasts about
// 3 frames, so no single saccade determines the slew; the saccades' commands fall at different
// phases of the frame clock, and together they sample the trajectory densely.
//
//   1. Pooled fit: slew, lag and D common, theta0 and a per saccade, least squares on the angles
//      (Ceres, autodiff), started from a grid over (slew, lag, D). Sigmas: the larger of the
//      covariance scaled by the residual variance and the jackknife over saccades (the fit
//      repeated without each saccade): the frames of one saccade share their errors (the disc's
//      centroid, the servo's PWM step and backlash, the frame clock's phase), so the covariance,
//      which counts every frame as independent, is several times too small. Then the angles'
//      scale (options.angle_scale_sigma) in quadrature: slew = angle / time scales with it.
//   2. Per saccade: its own slew (theta0, a free; lag and D the pooled ones): its peak angular
//      velocity V = slew (1 - exp(-a / (slew lag))) and its duration (the time the angular velocity
//      is above velocity_threshold_deg_per_s, the eye-tracking convention), with sigmas.
//   3. Main sequence: V(a) = Vmax (1 - exp(-a / C)) fitted to the saccades' peak velocities: for
//      this servo law Vmax is the slew and C = slew * lag. Duration(a) fitted with the same law's
//      duration (DurationS): a second slew and lag, from the durations.
// A saccade with too few measured frames, or whose fit fails, is a row with ok = false and why.
#include <string>
#include <vector>

namespace owlcal::fitting {

struct SaccadeTrace {
  int id = 0;
  std::vector<double> t_s;        // frame arrival time from the command [s], increasing
  std::vector<double> angle_deg;  // measured joint angle; NaN = not measured
};

struct MainSequenceFitOptions {
  double delay_min_s = 0, delay_max_s = 0.4;  // the delay's search window
  int rest_frames = 3;                        // last frames averaged for the end angle (the start guess)
  double velocity_threshold_deg_per_s = 30;   // duration: time above this angular velocity
  // Relative sigma of the measured angles' scale (the lens and head geometry they come through:
  // a scale error of the angles is the same error of every slew and of C, and no scatter shows
  // it). Added in quadrature to the slews' and C's sigmas; 0 = none.
  double angle_scale_sigma = 0;
  bool Check(std::string* why) const;
};

struct PooledSaccadeMotion {
  bool ok = false;
  std::string message;
  // Sigmas: the larger of the fit's (fit_*) and the jackknife's over saccades (jackknife_*).
  double slew_deg_per_s = 0, slew_sigma_deg_per_s = 0;
  double lag_s = 0, lag_sigma_s = 0;
  double delay_s = 0, delay_sigma_s = 0;
  double fit_slew_sigma_deg_per_s = 0, fit_lag_sigma_s = 0, fit_delay_sigma_s = 0;
  double jackknife_slew_sigma_deg_per_s = 0, jackknife_lag_sigma_s = 0, jackknife_delay_sigma_s = 0;
  int jackknife_saccades = 0;
  double scale_slew_sigma_deg_per_s = 0;  // slew x angle_scale_sigma, in slew_sigma_deg_per_s
  double rms_deg = 0;
  int num_frames = 0, num_saccades = 0;
};

struct SaccadeMeasurement {
  int id = 0;
  bool ok = false;
  std::string reason;
  int direction = 0;
  double start_deg = 0;
  double amplitude_deg = 0, amplitude_sigma_deg = 0;
  double slew_deg_per_s = 0, slew_sigma_deg_per_s = 0;  // its own slew (poorly determined when small)
  double peak_deg_per_s = 0, peak_sigma_deg_per_s = 0;
  double duration_s = 0, duration_sigma_s = 0;  // NaN: the peak stays below the threshold
  double rms_deg = 0;
  int num_frames = 0;
};

struct MainSequenceCurve {
  bool ok = false;
  std::string message;
  double vmax_deg_per_s = 0, vmax_sigma_deg_per_s = 0;  // = slew
  double c_deg = 0, c_sigma_deg = 0;                    // = slew * lag
  double lag_s = 0, lag_sigma_s = 0;                    // C / Vmax
  double rms_deg_per_s = 0;
  int num_saccades = 0;
};

struct DurationCurve {
  bool ok = false;
  std::string message;
  double slew_deg_per_s = 0, slew_sigma_deg_per_s = 0;
  double lag_s = 0, lag_sigma_s = 0;
  double rms_s = 0;
  int num_saccades = 0;
};

struct MainSequenceFit {
  PooledSaccadeMotion motion;
  std::vector<SaccadeMeasurement> saccades;  // one per trace, in order
  MainSequenceCurve peak;
  DurationCurve duration;
  double velocity_threshold_deg_per_s = 30;
};

MainSequenceFit FitMainSequence(const std::vector<SaccadeTrace>& traces, const MainSequenceFitOptions& options);

// The law above, for figures and truth: Y(tau), the peak velocity and the duration above v_th
// (NaN when the peak stays below v_th).
double SaccadeAngleDeg(double tau_s, double amplitude_deg, double slew_deg_per_s, double lag_s);
double PeakVelocityDegPerS(double amplitude_deg, double slew_deg_per_s, double lag_s);
double DurationS(double amplitude_deg, double slew_deg_per_s, double lag_s, double threshold_deg_per_s);

}  // namespace owlcal::fitting
