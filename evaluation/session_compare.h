#pragma once
// Side-by-side comparison of calibrations of one robot from different sessions: every chosen
// parameter per session with its sigma, and each pair of sessions' difference in units of its
// combined sigma, z = (b - a) / sqrt(sigma_a^2 + sigma_b^2) (sessions are independent image sets).
// |z| > z_changed says the robot (or its set-up) changed beyond the calibrations' noise; a
// parameter without sigma in either session gives z = NaN ("no sigma") rather than a verdict.
#include <string>
#include <vector>

#include "fitting/result.h"

namespace owlcal::evaluation {

struct NamedResult {
  std::string name;  // "session1"
  fitting::CalibrationResult result;
};

struct SessionCell {
  bool present = false;
  double value = 0, sigma = 0;
  bool determined = false;
};

struct SessionPairDiff {
  int a = 0, b = 0;          // session indices
  std::vector<double> diff;  // per parameter, b - a (NaN when absent)
  std::vector<double> z;     // per parameter, NaN without sigma
};

struct SessionComparison {
  std::vector<std::string> sessions;
  std::vector<std::string> parameters;  // names
  std::vector<std::string> units;
  std::vector<std::vector<SessionCell>> cells;  // [parameter][session]
  std::vector<SessionPairDiff> pairs;           // every a < b
  double z_changed = 3.0;
  // Parameters whose |z| > z_changed for some pair, as "name: s1->s2 z=..".
  std::vector<std::string> changed;
};

// names empty: every left.* right.* stereo.* parameter of the first session, in its order.
SessionComparison CompareSessions(const std::vector<NamedResult>& sessions,
                                  const std::vector<std::string>& names = {},
                                  double z_changed = 3.0);

}  // namespace owlcal::evaluation
