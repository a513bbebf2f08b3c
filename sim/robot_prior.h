#pragma once
// A prior over real Owls: draws random robot truths (sim/robot_truth.h) for Monte-Carlo checks
// of owlcal's uncertainties (bench/robot_prior_mc_bench.cc). Its ranges span the shipped
// robots (data/sim/owl_default_truth.yaml, owl_variant_a, owl_variant_b) and what real Owls
// show (FACTS: centres +-60 us, scales 8.8-11.8 us/deg, 1 or 5 us PWM steps, f 578-591 px on two
// real Owls, wider lenses on others; bench/sim_real_bench.cc for the image formation).
//
// Every value is drawn independently and uniformly in the range below (integers uniformly
// among the listed values); the robot file is the guide's (models::DefaultRobotConfig), so the
// truth disagrees with it as much as a real robot does.
//   servos, eyes (Rx Ry Lx Ly)      centre = robot file's +-60 us, deg_per_us 0.088-0.125,
//                                   quad_deg and cubic_deg -1.5..1.5 (monotone maps only),
//                                   hysteresis 0.5-6 us, dead band 1-3 us,
//                                   slew 280-460 deg/s, lag 15-70 ms
//   neck                            centre +-40 us, deg_per_us 0.100-0.125, hysteresis 2-8 us,
//                                   dead band 2-5 us, slew 280-360 deg/s, lag 35-70 ms
//   PWM quantum (all five)          1 us (70 %) or 5 us (pigpio's default sampling, 30 %)
//   end-stops                       each configured limit moved by -35..+20 us (negative: inside)
//   eye centres                     IPD 62.5-65.5 mm, y +-0.5 mm, z 28-32 mm ahead of the neck
//   camera mounting (cam_from_eye)  optical centre x, y +-2 mm, z 13-18 mm ahead of the eye
//                                   centre; rotation vector components +-1.5 deg
//   intrinsics (OpenCV 5)           fx 480-620 px, fy = fx * (1 +-0.003), cx 320 +-15, cy 240 +-15,
//                                   k1 = -0.08 - 0.12 * (620 - fx) / 140 +-0.04 (wider lenses
//                                   bend more), k2 0-0.12, p1 p2 +-0.001, k3 -0.03..0.01
//   stream                          noise 0.8-2.5 grey, JPEG quality 70-95, blur 1-2.2 px,
//                                   white 140-200 / black 40-70 grey, lens shading 0.1-0.5,
//                                   eye offset -5..12 ms, latency 67-133 ms, drops 0-2 %,
//                                   rolling shutter 20-33 ms
//   board (scene)                   the chessboard bows 0-1.2 mm along x, -0.3..0.3 mm along y
// Deterministic for a seed. Every drawn truth passes RobotTruth::Validate.
//
// Two other kinds of robot (issue 34) start from a prior robot, drawn with the same numbers as
// kPrior, and then draw more numbers from the same generator that replace some of its values;
// the rest is the prior's. kPrior draws exactly as before: these extra numbers are drawn only
// for the other kinds. Hand-written examples: tests/data/robots/owl_reassembled*_truth.yaml
// and owl_slow_servos*_truth.yaml.
//   kReassembled: a student took the head apart and put it back together
//     reversed horn                   one servo's truth direction is the opposite of the robot
//                                     file's; Rx, Ry, Lx, Ly 22.5 % each, the neck 10 %
//     centres                         the file's +- 50-90 us on the eyes, +- 40-70 us on the neck
//                                     (the sign random per servo)
//     end-stops                       every one 35-90 us inside the file's limit (the neck's 55-75)
//     PWM quantum (all five)          5 us (pigpio's default sampling)
//     eye centres                     IPD 62-69 mm (the prior's offsets kept)
//   kSlow: cheap, slow servos and a slow stream
//     servos (all five)               slew 150-250 deg/s, lag 60-140 ms, dead band 3-7 us,
//                                     hysteresis 2.5-4 us on the eyes and 5-7 us on the neck
//     neck end-stops                  each 30-50 us inside the file's limit
//     stream                          15 or 20 fps (even odds), latency 180-260 ms, eye offset
//                                     15-30 ms (the right eye after the left), rolling shutter
//                                     30-45 ms
//     intrinsics (OpenCV 8, rational) a wide replacement lens: fx 500-530 px, fy = fx * (1
//                                     +-0.003), k1 6-8, k4 = k1 + 0.8..1.2, k2 k3 k5 k6 0; cx, cy,
//                                     p1, p2 the prior's
//     socket                          rim half-angle 70-78 deg (a wider view needs a wider socket)
// A servo whose map is no longer monotone over its new end-stops gets new quad_deg and cubic_deg
// (the prior's ranges), as the prior draws them.
//
// Usage:
//   std::mt19937_64 rng(seed);
//   DrawnRobot r = DrawRobot(&rng, "prior-7");
//   DrawnRobot s = DrawRobot(&rng, "slow-7", RobotKind::kSlow);
//   VirtualOwlOptions o;  o.truth = r.truth;  o.scene = r.scene;
#include <cstdint>
#include <random>
#include <string>

#include "sim/robot_truth.h"
#include "sim/scene.h"
#include "sim/virtual_owl.h"

namespace owlcal::sim {

struct DrawnRobot {
  RobotTruth truth;
  SceneDescription scene;  // the default scene with this robot's board warp
  // The in-process virtual Owl of this robot and scene with noise seed `seed`.
  VirtualOwlOptions OwlOptions(uint64_t seed) const {
    VirtualOwlOptions o;
    o.truth = truth;
    o.scene = scene;
    o.seed = seed;
    return o;
  }
};

// Which population DrawRobot draws from (the header comment's ranges).
enum class RobotKind {
  kPrior,        // robots like real Owls, as the robot file describes them
  kReassembled,  // a reversed horn, centres and stops off the file's, 5 us PWM
  kSlow,         // slow laggy backlashed servos, a slow stream, a wide rational lens
};

// The kind's name as the bench spells it ("prior", "reassembled", "slow").
const char* RobotKindName(RobotKind kind);

// Draws one robot truth named `name` of `kind`. Throws std::invalid_argument (from
// RobotTruth::Validate) if a drawn truth is unphysical, which the ranges above rule out.
DrawnRobot DrawRobot(std::mt19937_64* rng, const std::string& name, RobotKind kind = RobotKind::kPrior);

}  // namespace owlcal::sim
