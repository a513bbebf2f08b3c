#pragma once
// What the AprilTag sheets add to the head fit (servo_sweep's `tag_targets`,
// protocols/protocol.h): the sweep's frames are searched for the chessboard and for the tag
// grids around it; both kinds of corner go into ONE head fit (fitting/head_fit.h), each kind
// whitened by the sigma its own residuals show (HeadFitOptions::noise_class_of_board).
//
// TagStudy compares that fit with the same fit on the chessboard views alone:
//   - coverage: per noise class the views and corners per eye, and per servo the pulse widths
//     at which each class was seen (the tags reach where the chessboard leaves the view);
//   - each servo map's sigma at both ends of its configured range (first-order propagation of
//     the map parameters' covariance, evaluation/servo_map_eval.h) with and without the tags, and
//     on the virtual Owl the fitted-minus-true angle there with both fits.
// results.json diagnostics.tags; the report's tables tag_coverage and tag_servo_ends.
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/observation.h"
#include "fitting/head_fit.h"
#include "fitting/result.h"
#include "models/head_model.h"
#include "models/robot_config.h"

namespace owlcal::pipeline {

// Noise classes of a dataset's targets, from the protocol its manifest records: aprilgrid
// targets "apriltag", chessboards "chessboard". Empty when the manifest names no targets.
std::map<std::string, std::string> NoiseClassesOfDataset(const std::string& dataset);

// Tag sizes [m] of a dataset's aprilgrid targets (HeadFitOptions::tag_size_of_board: their
// corners are compared with the detector's straight-edge corners, fitting/tag_edge_corner.h).
std::map<std::string, double> TagSizesOfDataset(const std::string& dataset);

// A head fit's joint covariance as results.json's diagnostics.covariance ({names, matrix}, a
// non-finite entry as 0); null when the fit has none.
nlohmann::json HeadCovarianceJson(const fitting::HeadFit& h);

// The views of the boards no noise class names "apriltag" (the chessboard-only fit's input).
std::vector<calib::View> WithoutTags(const std::vector<calib::View>& views,
                                     const std::map<std::string, std::string>& noise_class_of_board);

// The study above. `with_tags` is the fit on every view, `without` the fit on WithoutTags(views)
// (nullopt when it failed: the ends then have no "without" sigma and a note says why). `truth`:
// the virtual Owl's head in the fit's gauge, or null.
nlohmann::json TagStudy(const std::vector<calib::View>& views,
                        const std::map<std::string, std::string>& noise_class_of_board,
                        const fitting::HeadFit& with_tags,
                        const std::optional<fitting::HeadFit>& without,
                        const models::RobotConfig& config,
                        const models::HeadModel* truth);

}  // namespace owlcal::pipeline
