#pragma once
// Tables of the image-folder commands (calibrate-images, range-images) for the lab report:
//   ImageSetReportMarkdown  verdict, every parameter with its sigma, per-view RMS and tilt per eye
//                           (pair_keys[frame] names each pair; may be empty)
//   RangeTableCsv           name,status,true_cm,range_cm,error_cm,error_pct,sigma_cm,sigma_calib_cm,
//                           sigma_cov_cm,sigma_cv_cm,sigma_match_cm,z,disparity_px,sigma_disparity_px,
//                           dy_px,ncc,second_ncc,peak_ratio,lr_error_px,contrast,block_spread_px,
//                           roi_x,roi_y,roi_w,roi_h,ray_gap_mm,message (one row per pair; status ok,
//                           low_confidence or failed; empty cells when not ranged or no truth)
//   RangeTableMarkdown      the same for reading, with the summary line below
//   DatumFitMarkdown        the truth's datum and scale fit, errors before / after / leave-one-out
//   ScaleBudgetMarkdown     b - 1 split into calibration, matching and the truth (range_scale_budget.h)
// Values the data did not determine print as "-" (fitting/format.h), never as "nan".
#include <string>
#include <vector>

#include "evaluation/range_images_calib.h"
#include "evaluation/range_images_ranging.h"
#include "evaluation/range_scale_budget.h"
#include "fitting/range_datum_fit.h"

namespace owlcal::reports {

std::string ImageSetReportMarkdown(const evaluation::ImageSetCalibration& c, const std::vector<std::string>& pair_keys);
std::string RangeTableCsv(const std::vector<evaluation::RangeMeasurement>& m);
std::string RangeTableMarkdown(const std::vector<evaluation::RangeMeasurement>& m,
                               const evaluation::RangeSummary& s,
                               const std::string& title);
std::string DatumFitMarkdown(const fitting::DatumFit& fit);
std::string ScaleBudgetMarkdown(const evaluation::ScaleBudget& budget);

}  // namespace owlcal::reports
