#include "evaluation/session_compare.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "fitting/format.h"
#include "models/units.h"

namespace owlcal::evaluation {
namespace {}  // namespace

SessionComparison CompareSessions(const std::vector<NamedResult>& sessions,
                                  const std::vector<std::string>& names,
                                  double z_changed) {
  if (sessions.size() < 2) throw std::invalid_argument("CompareSessions needs >= 2 sessions");
  SessionComparison c;
  c.z_changed = z_changed;
  for (const auto& s : sessions) c.sessions.push_back(s.name);
  c.parameters = names;
  if (c.parameters.empty()) {
    for (const auto& p : sessions[0].result.parameters)
      if (p.name.rfind("left.", 0) == 0 || p.name.rfind("right.", 0) == 0 || p.name.rfind("stereo.", 0) == 0)
        c.parameters.push_back(p.name);
  }
  for (const auto& name : c.parameters) {
    std::vector<SessionCell> row;
    std::string unit;
    for (const auto& s : sessions) {
      SessionCell cell;
      if (const fitting::Parameter* p = s.result.Find(name)) {
        cell.present = true;
        cell.value = p->value;
        cell.determined = p->determined && std::isfinite(p->sigma);
        cell.sigma = cell.determined ? p->sigma : kNaN;
        if (unit.empty()) unit = p->unit;
      }
      row.push_back(cell);
    }
    c.cells.push_back(row);
    c.units.push_back(unit);
  }
  for (size_t a = 0; a < sessions.size(); ++a) {
    for (size_t b = a + 1; b < sessions.size(); ++b) {
      SessionPairDiff d;
      d.a = static_cast<int>(a);
      d.b = static_cast<int>(b);
      for (size_t i = 0; i < c.parameters.size(); ++i) {
        const SessionCell &x = c.cells[i][a], &y = c.cells[i][b];
        const double diff = x.present && y.present ? y.value - x.value : kNaN;
        const double s = std::hypot(x.sigma, y.sigma);
        const double z = x.determined && y.determined && s > 0 ? diff / s : kNaN;
        d.diff.push_back(diff);
        d.z.push_back(z);
        if (std::isfinite(z) && std::abs(z) > z_changed)
          c.changed.push_back(c.parameters[i] + ": " + c.sessions[a] + " -> " + c.sessions[b] +
                              " z = " + fitting::FixedOrDash(z, 1));
      }
      c.pairs.push_back(d);
    }
  }
  return c;
}

}  // namespace owlcal::evaluation
