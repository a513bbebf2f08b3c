#pragma once
// A covariance over named result parameters ("servo.Lx.deg_per_us", "head.ipd_mm", "left.fx"),
// and the change of one of them applied to a head model: what the sigma propagations of
// ranging (evaluation/ranging_eval.h) and of a stereo pose (fitting/pose_stereo.h) are built on.
#include <string>
#include <vector>

#include <Eigen/Core>

#include "fitting/result.h"
#include "models/head_model.h"

namespace owlcal::fitting {

// A parameter covariance over named result parameters, in the result's units.
struct NamedCovariance {
  std::vector<std::string> names;
  Eigen::MatrixXd matrix;
};

// The covariance of the parameters in `wanted` that the result has (determined, finite
// sigma): the block of diagnostics["covariance"] = {"names": [...], "matrix": [[...]]} when
// present, else diagonal from Parameter::sigma.
NamedCovariance CovarianceFromResult(const CalibrationResult& result, const std::vector<std::string>& wanted);

// Applies a change `delta` (in the parameter's result unit) of a named parameter to a head.
// Returns false for a name that does not map onto the head model.
bool PerturbHead(const std::string& name, double delta, models::HeadModel* head);

}  // namespace owlcal::fitting
