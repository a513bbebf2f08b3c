#pragma once
// `owlcal range-images`' workflow: range a target in stereo pairs with a calibration
// (evaluation/range_images_ranging.h), at known distances (the error against the truth, the
// truth's datum and scale fit and where the scale goes, evaluation/range_scale_budget.h) or
// unknown ones (range with sigma); every row with a status (ok, low_confidence, failed). Writes
// ranges.md, ranges.csv, scale_budget.json and the range figure (reports/image_set_tables.h).
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "evaluation/range_images_ranging.h"
#include "fitting/range_datum_fit.h"

namespace owlcal::pipeline {

struct RangeImagesRunOptions {
  std::string dir;                // folder of the image pairs
  std::string calib;              // results.json, calibration.yaml, intrinsics.xml (+ extrinsics.xml) or a folder
  std::string truth;              // truth CSV; "": every left*/right* pair of dir, distance unknown
  std::string out;                // output folder
  std::vector<int> roi;           // template x y w h in the left rectified image; empty: none
  std::string select = "centre";  // centre, texture, colour:NAME, tag[:ID] (calib/template_roi.h)
  double truth_sigma_cm = 0;      // uncertainty of the logged distances [cm]
  double datum_cm = 0;            // added to the depth from the optical centres [cm]
  bool mirror = false;            // flip each image horizontally first
  bool no_datum_fit = false;      // do not fit the truth's datum and scale
  int template_w = 64, template_h = 48, max_disparity = 256;  // [px]
  // False (and why) for a bad --select or --roi.
  bool Check(std::string* why) const;
};

struct RangeImagesRun {
  std::vector<evaluation::RangeMeasurement> ranges;  // one per pair, in the truth file's order
  evaluation::RangeSummary summary;
  fitting::DatumFit datum;    // ok = false when not fitted
  std::string markdown;       // ranges.md's text
  std::string figure;         // the figure's name (range_error or range_values)
  bool figure_drawn = false;  // its PNG and SVG exist (none without a range)
  std::string figure_error;   // why drawing it failed ("" when it did not fail)
};

// Pairs between progress lines on a long list.
inline constexpr size_t kRangeProgressEveryPairs = 100;

// Runs it and writes every file into options.out; `progress` gets a line every
// kRangeProgressEveryPairs pairs of a longer list. Throws std::invalid_argument for a ROI outside
// the rectified image or bad range options, and naming the file for unreadable input.
RangeImagesRun RunRangeImages(const RangeImagesRunOptions& options,
                              const std::function<void(const std::string&)>& progress);

}  // namespace owlcal::pipeline
