#include "fitting/session_compare.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "fitting/format.h"

namespace owlcal::fitting {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Decimals for a value of this magnitude and sigma: two significant digits of sigma.
int Decimals(double sigma, double value) {
  const double ref = std::isfinite(sigma) && sigma > 0 ? sigma : std::abs(value) * 1e-3;
  if (!(ref > 0)) return 3;
  return std::clamp(1 - static_cast<int>(std::floor(std::log10(ref))), 0, 6);
}

}  // namespace

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
      if (const Parameter* p = s.result.Find(name)) {
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
          c.changed.push_back(c.parameters[i] + ": " + c.sessions[a] + " -> " + c.sessions[b] + " z = " + FixedOrDash(z, 1));
      }
      c.pairs.push_back(d);
    }
  }
  return c;
}

std::string SessionComparisonMarkdown(const SessionComparison& c) {
  std::ostringstream md;
  md << "| parameter | unit |";
  for (const auto& s : c.sessions) md << " " << s << " |";
  for (const auto& p : c.pairs) md << " " << c.sessions[p.b] << " - " << c.sessions[p.a] << " (z) |";
  md << "\n|---|---|";
  for (size_t i = 0; i < c.sessions.size() + c.pairs.size(); ++i) md << "---|";
  md << "\n";
  for (size_t i = 0; i < c.parameters.size(); ++i) {
    md << "| " << c.parameters[i] << " | " << c.units[i] << " |";
    for (const auto& cell : c.cells[i]) {
      if (!cell.present) {
        md << " absent |";
      } else {
        const int dec = Decimals(cell.sigma, cell.value);
        md << " " << FixedOrDash(cell.value, dec) << " ± " << (cell.determined ? FixedOrDash(cell.sigma, dec) : "n/d") << " |";
      }
    }
    for (const auto& p : c.pairs) {
      const double z = p.z[i];
      md << " " << FixedOrDash(p.diff[i], 3) << " (" << (std::isfinite(z) ? FixedOrDash(z, 1) : "no sigma")
         << (std::isfinite(z) && std::abs(z) > c.z_changed ? " **changed**" : "") << ") |";
    }
    md << "\n";
  }
  md << "\n";
  if (c.changed.empty()) {
    md << "No parameter differs by more than " << FixedOrDash(c.z_changed, 0) << " sigma between sessions: the differences are "
       << "consistent with calibration noise.\n";
  } else {
    md << "Differences beyond " << FixedOrDash(c.z_changed, 0) << " sigma (the robot or its set-up changed, or a sigma is "
       << "too small):\n";
    for (const auto& s : c.changed) md << "- " << s << "\n";
  }
  return md.str();
}

std::string SessionComparisonCsv(const SessionComparison& c) {
  std::ostringstream csv;
  csv << std::setprecision(10) << "parameter,unit,session,value,sigma,z\n";
  for (size_t i = 0; i < c.parameters.size(); ++i) {
    for (size_t s = 0; s < c.sessions.size(); ++s) {
      const auto& cell = c.cells[i][s];
      if (!cell.present) continue;
      csv << c.parameters[i] << "," << c.units[i] << "," << c.sessions[s] << "," << cell.value << ","
          << (cell.determined ? std::to_string(cell.sigma) : "") << ",\n";
    }
    for (const auto& p : c.pairs) {
      csv << c.parameters[i] << "," << c.units[i] << "," << c.sessions[p.b] << "-" << c.sessions[p.a] << ","
          << p.diff[i] << ",," << (std::isfinite(p.z[i]) ? std::to_string(p.z[i]) : "") << "\n";
    }
  }
  return csv.str();
}

}  // namespace owlcal::fitting
