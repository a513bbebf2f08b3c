#include "reports/session_tables.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "fitting/format.h"

namespace owlcal::reports {
namespace {

using evaluation::SessionComparison;
using fitting::FixedOrDash;

// Decimals for a value of this magnitude and sigma: two significant digits of sigma.
int Decimals(double sigma, double value) {
  const double ref = std::isfinite(sigma) && sigma > 0 ? sigma : std::abs(value) * 1e-3;
  if (!(ref > 0)) return 3;
  return std::clamp(1 - static_cast<int>(std::floor(std::log10(ref))), 0, 6);
}

}  // namespace

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
        md << " " << FixedOrDash(cell.value, dec) << " ± " << (cell.determined ? FixedOrDash(cell.sigma, dec) : "n/d")
           << " |";
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
    md << "No parameter differs by more than " << FixedOrDash(c.z_changed, 0)
       << " sigma between sessions: the differences are "
       << "consistent with calibration noise.\n";
  } else {
    md << "Differences beyond " << FixedOrDash(c.z_changed, 0)
       << " sigma (the robot or its set-up changed, or a sigma is "
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

}  // namespace owlcal::reports
