#pragma once
// The camera-calibration figures a student needs to judge (and improve) a calibration, as
// Kalibr's report and mrcal's plots show them. Each is omitted when its data are missing.
//
//   view_rms               RMS reprojection error of every calibration view per eye [px], the
//                          worst views named on the plot and a retake threshold (median + 3
//                          scaled MADs); WorstViews() lists them for the text
//   residual_field_<eye>   each corner's residual as an arrow at its image position (scaled,
//                          colour = |residual| [px], viridis): a pattern means a model error
//   residual_hist_<eye>    histogram of the x and y residuals [px] with the normal density of
//                          their RMS: heavy tails mean outliers
//   uncertainty_<eye>      projection uncertainty at infinity over the image [px], worst
//                          direction (fitting/projection_uncertainty.h), with mrcal's
//                          valid-intrinsics region outlined
//   poses_3d               the two cameras and every board pose in 3D (gnuplot splot), each
//                          board drawn relative to the camera that saw it
#include <string>
#include <vector>

#include "reports/gnuplot_figure.h"
#include "reports/report_data.h"

namespace owlcal::reports {

struct WorstView {
  ViewStat view;
  double threshold_px = 0;  // median + 3 * 1.4826 * MAD of that eye's view RMS
};

// Views above their eye's threshold, worst first (at most `max_count`).
std::vector<WorstView> WorstViews(const ReportData& d, size_t max_count = 5);

std::vector<Figure> MakeCameraFigures(const ReportData& d);

}  // namespace owlcal::reports
