#pragma once
// Where the truth's fitted scale goes (range = a + b * truth, fitting/range_datum_fit.h): b - 1
// split into
//   calibration   focal length x baseline: 0 by construction (the ranges are the calibration's),
//                 with its sigma = sqrt(J C J^T), J = db/dp by central differences over every
//                 calibration parameter p (the rows' raw pixels held, every row re-triangulated
//                 and the datum refitted: the calibration error is common to all rows, so it is
//                 carried through the fit rather than added row by row), and sigma_cv = |b_A -
//                 b_B| / 2 from the calibration set's two halves;
//   matching      disparity bias: b refitted with a second matcher's disparities at the same
//                 templates (OpenCV's StereoSGBM median over the template, its own sub-pixel
//                 interpolation and left-right check), minus b; sigma = |db/d(disparity)| x the
//                 sub-pixel floor (a bias common to every row that neither matcher would see);
//   truth         the rest, (b - 1) - matching, with the datum fit's sigma of b: the ruler's
//                 scale and where the target was held.
// A term that could not be computed is NaN with a note (no covariance, no halves, no second
// matcher's disparity on enough rows).
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "evaluation/range_images_ranging.h"
#include "fitting/range_datum_fit.h"

namespace owlcal::evaluation {

struct ScaleBudget {
  bool ok = false;
  std::string message;  // why not computed
  int num_rows = 0;     // rows of the datum fit
  double b_minus_1 = 0, sigma_b = 0;
  double calib_sigma_cov = 0;  // NaN without a covariance
  double calib_sigma_cv = 0;   // NaN without the halves
  double matching = 0;         // b(second matcher) - b; NaN without it
  double matching_sigma = 0;   // |db/dd| x subpixel_floor_px
  double subpixel_floor_px = 0;
  double db_dd_per_px = 0;  // db per pixel of disparity bias common to every row
  int matching_rows = 0;    // rows the second matcher measured
  double truth = 0, truth_sigma = 0;
  std::vector<std::string> notes;
  std::string Sentence() const;  // one sentence with the numbers, for the report
};

// rows: the measurements; fit_rows: indices of the rows the datum fit used (in its order);
// second_disparity_px: per measurement, the second matcher's disparity at its template (NaN when
// none). The rectification is the one the measurements were matched in.
ScaleBudget SplitScale(const std::vector<RangeMeasurement>& rows,
                       const std::vector<int>& fit_rows,
                       const fitting::DatumFit& fit,
                       const fitting::StereoRig& rig,
                       const fitting::Rectification& rect,
                       const std::vector<double>& second_disparity_px,
                       double subpixel_floor_px = 0.1);

// {ok, message, num_rows, b_minus_1, sigma_b, calibration: {value: 0, sigma_cov, sigma_cv},
// matching: {value, sigma, db_per_px, rows, subpixel_floor_px}, truth: {value, sigma}, notes,
// sentence}; NaN as null.
nlohmann::json ScaleBudgetToJson(const ScaleBudget& b);

}  // namespace owlcal::evaluation
