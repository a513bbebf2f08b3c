#pragma once
// The points behind the calibration figures, from a stereo fit and the views it was fitted to:
// every corner's reprojection residual of the per-eye intrinsics fits (|residual| <= 5 px; the
// fit lists the rejected ones), the image coverage, each view's RMS with a name, and each
// board's outline in the camera frame (3D pose view). Shared by `owlcal calibrate` and
// `owlcal calibrate-images`.
#include <functional>
#include <string>
#include <vector>

#include "calib/observation.h"
#include "evaluation/calibration_run.h"
#include "fitting/stereo_fit.h"

namespace owlcal::evaluation {

// name_of(frame_index, eye): the view's name for the report (may be null: "frame N").
void AddFitPoints(const fitting::StereoFit& fit,
                  const std::vector<calib::View>& views,
                  const std::function<std::string(int frame, int eye)>& name_of,
                  CalibrationRun* data);

}  // namespace owlcal::evaluation
