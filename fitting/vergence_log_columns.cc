#include "fitting/vergence_log_columns.h"

#include <algorithm>
#include <cctype>
#include <stdexcept>

namespace owlcal::fitting {
namespace {

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string List(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s;
}

bool LooksNumeric(const std::string& cell) {
  if (cell.empty()) return false;
  size_t used = 0;
  try {
    std::stod(cell, &used);
  } catch (const std::exception&) {
    return false;
  }
  return used == cell.size();
}

std::string UnitSuffix(const std::string& lower_name) {
  for (const char* u : {"_mm", "_cm", "_m"})
    if (lower_name.ends_with(u)) return std::string(u + 1);
  return "";
}

bool DistanceLike(const std::string& lower_name) {
  for (const char* w : {"dist", "range", "depth", "estimate", "actual", "true"})
    if (lower_name.find(w) != std::string::npos) return true;
  return !UnitSuffix(lower_name).empty();
}

}  // namespace

std::string VergenceColumns::Describe() const {
  std::string s = "distance: " + distance_name + " (" + distance_unit + "), Rx: " + rx_name + ", Lx: " + lx_name +
                  ", run: " + (run < 0 ? std::string("none (one run)") : run_name);
  if (!ignored.empty()) s += "; ignored: " + List(ignored);
  return s;
}

VergenceColumns ResolveVergenceColumns(const std::vector<std::string>& header,
                                       const VergenceColumnRequest& req,
                                       const std::string& path) {
  if (!header.empty() &&
      std::all_of(header.begin(), header.end(), [](const std::string& c) { return c.empty() || LooksNumeric(c); }))
    throw std::runtime_error(path +
                             ": line 1 is numbers, not a header; add a header line naming the columns "
                             "(a true distance such as distance_cm, and the eye-pan PWM Rx and Lx)");
  std::vector<std::string> lower;
  for (const auto& h : header) lower.push_back(Lower(h));
  auto find_named = [&](const std::string& name, const char* option) {
    const auto it = std::find(lower.begin(), lower.end(), Lower(name));
    if (it == lower.end())
      throw std::runtime_error(path + ": " + option + " '" + name + "' is not a column of the header (" + List(header) +
                               ")");
    return static_cast<int>(it - lower.begin());
  };
  auto find_auto = [&](std::initializer_list<const char*> names) {
    for (const char* n : names) {
      const auto it = std::find(lower.begin(), lower.end(), n);
      if (it != lower.end()) return static_cast<int>(it - lower.begin());
    }
    return -1;
  };
  VergenceColumns c;
  c.rx = req.rx.empty() ? find_auto({"rx", "rx_us", "rx_pwm"}) : find_named(req.rx, "--rx-column");
  c.lx = req.lx.empty() ? find_auto({"lx", "lx_us", "lx_pwm"}) : find_named(req.lx, "--lx-column");
  c.run = req.run.empty() ? find_auto({"run"}) : find_named(req.run, "--run-column");
  if (c.rx < 0)
    throw std::runtime_error(path + ": no right-eye pan PWM column (Rx, Rx_us or Rx_pwm) in the header (" +
                             List(header) + "); name it with --rx-column");
  if (c.lx < 0)
    throw std::runtime_error(path + ": no left-eye pan PWM column (Lx, Lx_us or Lx_pwm) in the header (" +
                             List(header) + "); name it with --lx-column");
  for (int i = 0; i < static_cast<int>(header.size()); ++i)
    if (i != c.rx && i != c.lx && i != c.run && DistanceLike(lower[i])) c.distance_like.push_back(header[i]);
  if (!req.distance.empty()) {
    c.distance = find_named(req.distance, "--distance-column");
  } else if (c.distance_like.size() == 1) {
    c.distance = find_named(c.distance_like[0], "--distance-column");
  } else if (c.distance_like.empty()) {
    throw std::runtime_error(path + ": no distance column in the header (" + List(header) +
                             "); name the true distance with --distance-column");
  } else {
    throw std::runtime_error(path + ": " + std::to_string(c.distance_like.size()) + " distance-like columns (" +
                             List(c.distance_like) +
                             "): which is the TRUE distance? Name it with --distance-column (the others are "
                             "estimates owlcal must not fit to)");
  }
  if (c.distance == c.rx || c.distance == c.lx || c.distance == c.run)
    throw std::runtime_error(path + ": --distance-column '" + header[c.distance] +
                             "' is also the Rx, Lx or run column");
  c.distance_name = header[c.distance];
  c.rx_name = header[c.rx];
  c.lx_name = header[c.lx];
  if (c.run >= 0) c.run_name = header[c.run];
  c.distance_unit = req.distance_unit.empty() ? UnitSuffix(lower[c.distance]) : Lower(req.distance_unit);
  if (c.distance_unit == "m")
    c.distance_scale_m = 1;
  else if (c.distance_unit == "cm")
    c.distance_scale_m = 0.01;
  else if (c.distance_unit == "mm")
    c.distance_scale_m = 0.001;
  else if (req.distance_unit.empty())
    throw std::runtime_error(path + ": distance column '" + c.distance_name +
                             "' has no unit suffix (_m, _cm, _mm); give --distance-unit");
  else
    throw std::runtime_error(path + ": --distance-unit '" + req.distance_unit + "': use m, cm or mm");
  for (int i = 0; i < static_cast<int>(header.size()); ++i)
    if (i != c.distance && i != c.rx && i != c.lx && i != c.run) c.ignored.push_back(header[i]);
  return c;
}

}  // namespace owlcal::fitting
