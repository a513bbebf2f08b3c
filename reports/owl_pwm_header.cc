#include "reports/owl_pwm_header.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "fitting/pixel_pwm_map.h"
#include "models/servo_map.h"
#include "reports/table.h"

namespace owlcal::reports {
namespace {

// A C floating literal (always with a '.' or an exponent), 10 significant digits.
std::string FloatLiteral(double v) {
  std::string s = Fmt(v, 10);
  if (s.find_first_of(".e") == std::string::npos) s += ".0";
  return s;
}

const fitting::Parameter* Determined(const fitting::CalibrationResult& r, int servo, const char* field) {
  const fitting::Parameter* p = r.Find(std::string("servo.") + models::kServoNames[servo] + "." + field);
  return p && p->determined && std::isfinite(p->value) ? p : nullptr;
}

constexpr int kPixelGridStepPx = 40;

// Each servo's limits (the limits run's recommendation, else the robot file's) and centre (fitted,
// else configured), with where each came from.
struct OwlServoEnds {
  int lo[models::kNumServos], hi[models::kNumServos], centre[models::kNumServos];
  std::string centre_note[models::kNumServos], limit_note[models::kNumServos];
  // The guide names ends by direction: R/L = the robot's right/left (pan), T/B = top/bottom.
  int End(const models::RobotConfig& config, int s, bool positive_angle) const {
    return (config.servos[s].direction > 0) == positive_angle ? hi[s] : lo[s];
  }
};

OwlServoEnds OwlServoEndsOf(const fitting::CalibrationResult& r,
                            const models::RobotConfig& config,
                            const evaluation::LimitsEvaluation* limits) {
  OwlServoEnds e;
  for (int s = 0; s < models::kNumServos; ++s) {
    e.lo[s] = config.servos[s].min_us;
    e.hi[s] = config.servos[s].max_us;
    e.limit_note[s] = "low configured, high configured";
    if (limits) {
      for (const auto& l : limits->servos) {
        if (l.servo != s) continue;
        e.lo[s] = l.recommended_min_us;
        e.hi[s] = l.recommended_max_us;
        e.limit_note[s] = std::string("low ") +
                          (l.measured_min_us ? std::string("measured (") + evaluation::LimitCauseName(l.min_cause) + ")"
                                             : std::string("configured")) +
                          ", high " +
                          (l.measured_max_us ? std::string("measured (") + evaluation::LimitCauseName(l.max_cause) + ")"
                                             : std::string("configured"));
      }
    }
    e.centre[s] = config.servos[s].centre_us;
    e.centre_note[s] = "configured";
    if (const fitting::Parameter* p = Determined(r, s, "centre_us")) {
      e.centre[s] = int(std::lround(p->value));
      e.centre_note[s] = "fitted " + Fmt(p->value, 6) + " +/- " + Fmt(p->sigma, 2) + " us";
    }
  }
  return e;
}

// The header's comment and the course's range constants.
void WriteOwlRanges(const fitting::CalibrationResult& r,
                    const models::RobotConfig& config,
                    const OwlServoEnds& ends,
                    std::ostringstream* out) {
  std::ostringstream& o = *out;
  using models::kLx;
  using models::kLy;
  using models::kNeck;
  using models::kRx;
  using models::kRy;
  o << "/* owl-pwm.h: servo limits, centres and PWM <-> angle maps of this Owl (" << config.name
    << "), measured by owlcal " << r.software_version << ".\n"
    << " * Valid C (C99) and C++; include it from as many files as you like (static const objects and\n"
    << " * static inline functions only). The first block uses the course's names (Owl user guide, code\n"
    << " * snippet 5): include this header instead of the hand-set values.\n";
  for (int s = 0; s < models::kNumServos; ++s)
    o << " *   " << models::kServoNames[s] << ": limits " << ends.limit_note[s] << "; centre " << ends.centre_note[s]
      << "\n";
  o << " */\n#ifndef OWL_PWM_H\n#define OWL_PWM_H\n\n/* OWL eye ranges (course naming) */\n"
    << "static const int RyB = " << ends.End(config, kRy, false) << "; /* (bottom) to */\n"
    << "static const int RyT = " << ends.End(config, kRy, true) << "; /* (top) */\n"
    << "static const int RxR = " << ends.End(config, kRx, true) << "; /* (right) to */\n"
    << "static const int RxL = " << ends.End(config, kRx, false) << "; /* (left) */\n"
    << "static const int LyB = " << ends.End(config, kLy, false) << "; /* (bottom) to */\n"
    << "static const int LyT = " << ends.End(config, kLy, true) << "; /* (top) */\n"
    << "static const int LxR = " << ends.End(config, kLx, true) << "; /* (right) to */\n"
    << "static const int LxL = " << ends.End(config, kLx, false) << "; /* (left) */\n"
    << "static const int NeckR = " << ends.End(config, kNeck, true) << ";\n"
    << "static const int NeckL = " << ends.End(config, kNeck, false) << ";\n"
    << "static const int RxC = " << ends.centre[kRx] << ";\n"
    << "static const int RyC = " << ends.centre[kRy] << ";\n"
    << "static const int LxC = " << ends.centre[kLx] << ";\n"
    << "static const int LyC = " << ends.centre[kLy] << ";\n"
    << "static const int NeckC = " << ends.centre[kNeck] << ";\n"
    << "/* The ranges as the course computes them (written out: C needs constant initialisers). */\n"
    << "static const int RyRange = " << ends.End(config, kRy, true) - ends.End(config, kRy, false)
    << "; /* RyT - RyB */\n"
    << "static const int RxRange = " << ends.End(config, kRx, true) - ends.End(config, kRx, false)
    << "; /* RxR - RxL */\n"
    << "static const int LyRange = " << ends.End(config, kLy, true) - ends.End(config, kLy, false)
    << "; /* LyT - LyB (reflected so negative) */\n"
    << "static const int LxRange = " << ends.End(config, kLx, true) - ends.End(config, kLx, false)
    << "; /* LxR - LxL */\n"
    << "static const int NeckRange = " << ends.End(config, kNeck, false) - ends.End(config, kNeck, true)
    << "; /* NeckL - NeckR */\n\n";
}

// The servo maps (OwlServoMap), the IPD and the map functions.
void WriteOwlServoMaps(const fitting::CalibrationResult& r,
                       const models::RobotConfig& config,
                       const OwlServoEnds& ends,
                       std::ostringstream* out) {
  std::ostringstream& o = *out;
  const models::HeadModel& h = *r.head;
  o << "/* The fitted map of each servo (owlcal models/servo_map.h). Angles in degrees, positive to the\n"
    << " * robot's right (pan, neck) and up (tilt):\n"
    << " *   x         = (pwm_us - centre_us) / norm_us\n"
    << " *   angle_deg = direction * (deg_per_us * (pwm_us - centre_us) + quad_deg * x^2 + cubic_deg * x^3)\n"
    << " * at the middle of the backlash band: a pulse width reached from below acts as pwm_us -\n"
    << " * hysteresis_us, from above as pwm_us + hysteresis_us. direction = +1: increasing PWM turns\n"
    << " * right (pan, neck) or up (tilt); -1: left or down (the left eye's tilt and the neck run backwards).\n"
    << " * min_us, max_us: never command outside them. fitted = 0: the data did not determine this map;\n"
    << " * it holds the course's nominal values (0.113 deg/us at the configured centre). */\n"
    << "typedef struct OwlServoMap {\n  const char* name;\n  int direction;\n"
    << "  double centre_us, deg_per_us, quad_deg, cubic_deg, norm_us, hysteresis_us;\n"
    << "  int min_us, max_us;\n  int fitted;\n} OwlServoMap;\n\n";
  for (int s = 0; s < models::kNumServos; ++s) {
    const bool fitted = Determined(r, s, "deg_per_us") != nullptr;
    const auto& p = h.servo_params[s];
    const double c = fitted ? p[0] : config.servos[s].centre_us;
    const double k = fitted ? p[1] : config.servos[s].nominal_deg_per_us;
    const double q = fitted ? p[2] : 0.0, cu = fitted ? p[3] : 0.0, hy = fitted ? p[4] : 0.0;
    const int dir = fitted ? h.directions[s] : config.servos[s].direction;
    o << "static const OwlServoMap Owl" << models::kServoNames[s] << " = {\"" << models::kServoNames[s] << "\", " << dir
      << ", " << FloatLiteral(c) << ", " << FloatLiteral(k) << ", " << FloatLiteral(q) << ", " << FloatLiteral(cu)
      << ", " << FloatLiteral(models::ServoMap::kNormUs) << ", " << FloatLiteral(hy) << ", " << ends.lo[s] << ", "
      << ends.hi[s] << ", " << (fitted ? 1 : 0) << "};";
    if (fitted && !models::ServoMap::IsMonotone(p.data(), dir, ends.lo[s], ends.hi[s]))
      o << " /* not monotone over its limits: OwlDegToPwm returns one of the solutions */";
    o << "\n";
  }
  const fitting::Parameter* ipd = r.Find("head.ipd_mm");
  const bool ipd_ok = ipd && ipd->determined && std::isfinite(ipd->value);
  o << "\n/* Inter-pupillary distance [mm]" << (ipd_ok ? "" : " (design value: not determined)") << ". */\n"
    << "static const double OwlIpdMm = " << FloatLiteral(ipd_ok ? ipd->value : config.ipd_m * 1000) << ";\n\n";
  o << "/* Joint angle [deg] at a pulse width [us] (middle of the backlash band). */\n"
    << "static inline double OwlPwmToDeg(const OwlServoMap* m, double pwm_us) {\n"
    << "  const double du = pwm_us - m->centre_us;\n"
    << "  const double x = du / m->norm_us;\n"
    << "  return m->direction * (m->deg_per_us * du + m->quad_deg * x * x + m->cubic_deg * x * x * x);\n"
    << "}\n\n"
    << "/* The pulse width [us] for a joint angle [deg], rounded to 1 us and clamped to [min_us, max_us]:\n"
    << " * an angle beyond what the limits reach gives the limit. Bisection (no maths library needed). */\n"
    << "static inline int OwlDegToPwm(const OwlServoMap* m, double angle_deg) {\n"
    << "  double lo = m->min_us, hi = m->max_us;\n"
    << "  const double a_lo = OwlPwmToDeg(m, lo), a_hi = OwlPwmToDeg(m, hi);\n"
    << "  const double sense = a_hi >= a_lo ? 1.0 : -1.0;\n"
    << "  int i, u;\n"
    << "  if ((angle_deg - a_lo) * sense <= 0.0) return m->min_us;\n"
    << "  if ((angle_deg - a_hi) * sense >= 0.0) return m->max_us;\n"
    << "  for (i = 0; i < 64; ++i) {\n"
    << "    const double mid = 0.5 * (lo + hi);\n"
    << "    if ((OwlPwmToDeg(m, mid) - angle_deg) * sense < 0.0) lo = mid;\n"
    << "    else hi = mid;\n"
    << "  }\n"
    << "  u = (int)(0.5 * (lo + hi) + 0.5);\n"
    << "  return u < m->min_us ? m->min_us : (u > m->max_us ? m->max_us : u);\n"
    << "}\n\n";
}

// The pixel -> PWM map (fitting/pixel_pwm_map.h) as a grid of pulse-width changes.
void WriteOwlPixelGrid(const models::HeadModel& h, const models::RobotConfig& config, std::ostringstream* out) {
  std::ostringstream& o = *out;
  const fitting::PixelPwmGrid g = fitting::MakePixelPwmGrid(h, config, kPixelGridStepPx);
  o << "/* Pixel -> PWM (the course's \"calibrate servo to cameras ... give a map\"): the change of an eye's\n"
    << " * pan and tilt pulse widths [us] that brings what the eye sees at pixel (x, y) to its image centre\n"
    << " * (principal point), for a distant target, computed with the fitted head at the centre pose on a\n"
    << " * grid every " << kPixelGridStepPx
    << " px (owlcal exports/pixel_pwm.csv has the same grid with the exact pulse widths).\n"
    << " * OwlPixelToPwm interpolates it bilinearly and adds the change to the current pulse widths: exact\n"
    << " * at the centre pose, a small-angle approximation elsewhere (repeat the step once the eye has moved).\n"
    << " * Results are clamped to the servo limits. eye: 0 left (Lx, Ly), 1 right (Rx, Ry). */\n"
    << "#define OWL_PIXEL_GRID_COLS " << g.cols << "\n#define OWL_PIXEL_GRID_ROWS " << g.rows << "\n"
    << "static const double OwlPixelGridX[OWL_PIXEL_GRID_COLS] = {";
  for (int i = 0; i < g.cols; ++i) o << (i ? ", " : "") << FloatLiteral(g.xs[i]);
  o << "};\nstatic const double OwlPixelGridY[OWL_PIXEL_GRID_ROWS] = {";
  for (int i = 0; i < g.rows; ++i) o << (i ? ", " : "") << FloatLiteral(g.ys[i]);
  o << "};\n/* [eye][row][col][0 = pan change, 1 = tilt change] in us */\n"
    << "static const double OwlPixelGridDeltaUs[2][OWL_PIXEL_GRID_ROWS][OWL_PIXEL_GRID_COLS][2] = {\n";
  for (int e = 0; e < 2; ++e) {
    o << "  {\n";
    for (int row = 0; row < g.rows; ++row) {
      o << "    {";
      for (int col = 0; col < g.cols; ++col) {
        const auto& cell = g.rows_data[(e * g.rows + row) * g.cols + col];
        o << (col ? ", " : "") << "{" << FloatLiteral(cell.ok ? cell.delta_pan_us : 0.0) << ", "
          << FloatLiteral(cell.ok ? cell.delta_tilt_us : 0.0) << "}";
      }
      o << "}" << (row + 1 < g.rows ? "," : "") << "\n";
    }
    o << "  }" << (e == 0 ? "," : "") << "\n";
  }
  o << "};\n\n"
    << "static inline int OwlClampUs(const OwlServoMap* m, double us) {\n"
    << "  const int u = (int)(us + (us >= 0.0 ? 0.5 : -0.5));\n"
    << "  return u < m->min_us ? m->min_us : (u > m->max_us ? m->max_us : u);\n"
    << "}\n\n"
    << "/* Pulse widths that centre pixel (x_px, y_px) of `eye`, from its current pan_now_us, tilt_now_us. */\n"
    << "static inline void OwlPixelToPwm(int eye, double x_px, double y_px, int pan_now_us, int tilt_now_us,\n"
    << "                                 int* pan_us, int* tilt_us) {\n"
    << "  int i = 0, j = 0, k;\n"
    << "  double fx, fy, d[2];\n"
    << "  const OwlServoMap* pan = eye ? &OwlRx : &OwlLx;\n"
    << "  const OwlServoMap* tilt = eye ? &OwlRy : &OwlLy;\n"
    << "  const int e = eye ? 1 : 0;\n"
    << "  while (i < OWL_PIXEL_GRID_COLS - 2 && x_px > OwlPixelGridX[i + 1]) ++i;\n"
    << "  while (j < OWL_PIXEL_GRID_ROWS - 2 && y_px > OwlPixelGridY[j + 1]) ++j;\n"
    << "  fx = (x_px - OwlPixelGridX[i]) / (OwlPixelGridX[i + 1] - OwlPixelGridX[i]);\n"
    << "  fy = (y_px - OwlPixelGridY[j]) / (OwlPixelGridY[j + 1] - OwlPixelGridY[j]);\n"
    << "  for (k = 0; k < 2; ++k)\n"
    << "    d[k] = (1 - fy) * ((1 - fx) * OwlPixelGridDeltaUs[e][j][i][k] + fx * OwlPixelGridDeltaUs[e][j][i + 1][k]) "
       "+\n"
    << "           fy * ((1 - fx) * OwlPixelGridDeltaUs[e][j + 1][i][k] + fx * OwlPixelGridDeltaUs[e][j + 1][i + "
       "1][k]);\n"
    << "  *pan_us = OwlClampUs(pan, pan_now_us + d[0]);\n"
    << "  *tilt_us = OwlClampUs(tilt, tilt_now_us + d[1]);\n"
    << "}\n\n#endif /* OWL_PWM_H */\n";
}

}  // namespace

std::string OwlPwmHeader(const fitting::CalibrationResult& r,
                         const models::RobotConfig& config,
                         const evaluation::LimitsEvaluation* limits) {
  bool any_map = false;
  for (int s = 0; s < models::kNumServos; ++s) any_map = any_map || Determined(r, s, "deg_per_us");
  if (!r.head || !any_map)
    throw std::runtime_error("owl-pwm.h: no servo map was fitted (no servo sweep in this calibration)");
  const models::HeadModel& h = *r.head;
  const OwlServoEnds ends = OwlServoEndsOf(r, config, limits);
  std::ostringstream o;
  WriteOwlRanges(r, config, ends, &o);
  WriteOwlServoMaps(r, config, ends, &o);
  WriteOwlPixelGrid(h, config, &o);
  return o.str();
}

}  // namespace owlcal::reports
