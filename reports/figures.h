#pragma once
// The report's figures, built from ReportData (reports/report_data.h) and drawn with
// reports/gnuplot_figure.h. Each Make* returns nullopt when the data for it are missing.
//
//   servo_maps                 joint angle [deg] vs pulse width [us], every fitted servo (+ truth)
//   servo_<S>_deviation        fitted map minus the course's nominal map [deg] with the +-2 sigma
//                              band from the covariance, the truth (virtual Owl)
//   view_rms, residual_field_<eye>, residual_hist_<eye>, uncertainty_<eye>, poses_3d
//                              the calibration views and corners: reports/camera_figures.h
//   distortion_<eye>           lens distortion displacement field [px]
//   range_error                relative range error [%] vs true distance [m]: calibrated with
//                              +-2 sigma bars, the course's nominal method, theory curves
//   step_responses             fraction of the step vs time [s] per gain
//   settling_vs_gain           2 % settling time [s] vs gain: delayed P-loop model, measured,
//                              K_crit and the physical lower bound
//   limits                     configured vs measured range per servo [us]
//   coverage                   detected corners in the image [px] per eye
#include <optional>
#include <vector>

#include "reports/gnuplot_figure.h"
#include "reports/report_data.h"

namespace owlcal::reports {

std::vector<Figure> MakeServoFigures(const ReportData& d);
std::vector<Figure> MakeDistortionFigures(const ReportData& d);
std::optional<Figure> MakeRangeErrorFigure(const ReportData& d);
std::optional<Figure> MakeStepResponseFigure(const ReportData& d);
std::optional<Figure> MakeSettlingFigure(const ReportData& d);
std::optional<Figure> MakeLimitsFigure(const ReportData& d);
std::optional<Figure> MakeCoverageFigure(const ReportData& d);

// All of the above that have data, in report order.
std::vector<Figure> MakeAllFigures(const ReportData& d);

}  // namespace owlcal::reports
