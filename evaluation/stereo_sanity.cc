#include "evaluation/stereo_sanity.h"

#include <cmath>

#include <Eigen/Geometry>

#include "fitting/format.h"

namespace owlcal::evaluation {

RigExpectation RigExpectation::Owl() { return RigExpectation(); }

RigExpectation RigExpectation::Generic() {
  RigExpectation e;
  e.name = "generic";
  e.ipd_m = 0;
  e.focal_min_px = e.focal_max_px = 0;
  e.max_focal_mismatch = 0.10;
  return e;
}

bool RigExpectation::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (ipd_m < 0 || !(ipd_tolerance_m > 0)) return fail("ipd_m must be >= 0 and ipd_tolerance_m > 0");
  if (focal_max_px < focal_min_px || focal_min_px < 0) return fail("focal range must satisfy 0 <= min <= max");
  if (!(reference_width_px > 0)) return fail("reference_width_px must be > 0");
  if (!(max_rotation_deg > 0 && max_off_axis_fraction > 0 && max_principal_offset_fraction > 0 &&
        max_aspect_error > 0 && max_focal_mismatch > 0))
    return fail("the tolerances (rotation, off-axis, principal point, aspect, focal mismatch) must be > 0");
  return true;
}

StereoSanity CheckStereoSanity(const models::CameraIntrinsics cameras[2],
                               const models::Rigid3d& right_from_left,
                               double length_unit_m,
                               const RigExpectation& e) {
  StereoSanity s;
  auto add = [&](const std::string& check, bool unusable, const std::string& message) {
    s.findings.push_back({check, unusable, message});
  };
  const Eigen::Vector3d t = right_from_left.translation;
  const double n = t.norm();
  const bool metric = length_unit_m > 0;
  const std::string unit = metric ? "mm" : "target units";
  const double to_shown = metric ? length_unit_m * 1000 : 1.0;
  // Every limit below is the rig's: the messages name it.
  const std::string rig_limit = ", the " + e.name + " rig's limit";
  const std::string not_owl =
      e.name == "owl" ? " If this is not an Owl, --rig generic judges it as a generic stereo pair." : "";
  if (!(n > 0)) {
    add("t_direction", true, "T = 0: the two cameras are at the same place; the stereo fit is meaningless");
    return s;
  }
  if (t.x() >= 0) {
    s.mirrored_or_swapped = true;
    add("tx_sign",
        true,
        "T_x = +" + fitting::FixedOrDash(t.x() * to_shown, 1) + " " + unit +
            ": the right camera is on the LEFT of the left camera, which is physically impossible when left* is "
            "the left eye. The set is mirrored (halves cut from the Owl's 1280x480 stream without the course "
            "code's flip: calibrate again with --mirror) or its eyes are swapped (left and right files or halves "
            "exchanged: calibrate again with --swap). To tell which: in a mirrored image, text reads backwards "
            "(on Owl images the streaming server's watermark reads normally at the top of the right eye's image "
            "when the set is mirrored); a swapped set shows that watermark at the top of left* instead");
  }
  const double off_axis = std::hypot(t.y(), t.z()) / n;
  if (off_axis > e.max_off_axis_fraction)
    add("t_direction",
        false,
        "T = (" + fitting::FixedOrDash(t.x() * to_shown, 1) + ", " + fitting::FixedOrDash(t.y() * to_shown, 1) + ", " +
            fitting::FixedOrDash(t.z() * to_shown, 1) + ") " + unit + ": " + fitting::FixedOrDash(100 * off_axis, 0) +
            " % of the baseline is off the x axis (> " + fitting::FixedOrDash(100 * e.max_off_axis_fraction, 0) + " %" +
            rig_limit + "); side-by-side eyes have T along x. Check the image pairing (same number = same instant)");
  if (metric && e.ipd_m > 0) {
    const double b = n * length_unit_m;
    if (std::abs(b - e.ipd_m) > e.ipd_tolerance_m) {
      std::string hint;
      const double ratio = b / e.ipd_m;
      for (double k : {0.5, 2.0, 10.0, 0.1, 25.4, 1 / 25.4})
        if (std::abs(ratio / k - 1) < 0.15)
          hint = " The ratio " + fitting::FixedOrDash(ratio, 2) +
                 " suggests the target file's square size is off by a factor " +
                 fitting::FixedOrDash(k, k < 1 ? 3 : 1) + " (the baseline scales with it).";
      add("baseline",
          false,
          "baseline " + fitting::FixedOrDash(b * 1000, 1) + " mm, but the " + e.name + " rig's IPD is " +
              fitting::FixedOrDash(e.ipd_m * 1000, 1) + " +- " + fitting::FixedOrDash(e.ipd_tolerance_m * 1000, 1) +
              " mm: check the square size in the target file and the robot's IPD." + hint + not_owl);
    }
  }
  const double angle_deg = Eigen::AngleAxisd(right_from_left.rotation).angle() * 180 / M_PI;
  if (angle_deg > e.max_rotation_deg) {
    const Eigen::AngleAxisd aa(right_from_left.rotation);
    const Eigen::Vector3d rv = aa.axis() * aa.angle() * 180 / M_PI;
    add("rotation",
        false,
        "the cameras are rotated by " + fitting::FixedOrDash(angle_deg, 1) +
            " deg relative to each other (rotation vector " + fitting::FixedOrDash(rv.x(), 1) + ", " +
            fitting::FixedOrDash(rv.y(), 1) + ", " + fitting::FixedOrDash(rv.z(), 1) + " deg; > " +
            fitting::FixedOrDash(e.max_rotation_deg, 0) + rig_limit +
            "): eyes toed in, a loose camera or mismatched pairs. For a stereo calibration park both eyes "
            "parallel (the centre pose) and keep them still");
  }
  const char* eye[2] = {"left", "right"};
  const double scale = cameras[0].width / e.reference_width_px;
  for (int i = 0; i < 2; ++i) {
    const auto& p = cameras[i].params;
    const double fx = p[0], fy = p[1];
    if (e.focal_max_px > 0) {
      const double lo = e.focal_min_px * scale, hi = e.focal_max_px * scale;
      for (double f : {fx, fy}) {
        if (f < lo || f > hi) {
          add("focal",
              false,
              std::string(eye[i]) + " eye: f = " + fitting::FixedOrDash(f, 1) + " px is outside the " + e.name +
                  " lens family (" + fitting::FixedOrDash(lo, 0) + "-" + fitting::FixedOrDash(hi, 0) + " px at " +
                  std::to_string(cameras[i].width) +
                  " px wide; a 3.6 mm lens on the OV5647 gives 635 px by its spec, 578-591 px measured): another "
                  "lens or camera, an image size that is not the sensor's, or a set that let f trade against the "
                  "board distance (tilt the board)." +
                  not_owl);
          break;
        }
      }
    }
    if (std::abs(fx / fy - 1) > e.max_aspect_error)
      add("focal",
          false,
          std::string(eye[i]) + " eye: fx / fy = " + fitting::FixedOrDash(fx / fy, 3) + " (the " + e.name +
              " rig allows 1 +- " + fitting::FixedOrDash(e.max_aspect_error, 3) +
              "): the sensor's pixels are square, so the set does not pin the focal length (tilt the board about "
              "both axes) or the images were resized unevenly");
    const double dx = p[2] - (cameras[i].width - 1) / 2.0, dy = p[3] - (cameras[i].height - 1) / 2.0;
    if (std::hypot(dx, dy) > e.max_principal_offset_fraction * cameras[i].width)
      add("principal_point",
          false,
          std::string(eye[i]) + " eye: principal point (" + fitting::FixedOrDash(p[2], 1) + ", " +
              fitting::FixedOrDash(p[3], 1) + ") is " + fitting::FixedOrDash(std::hypot(dx, dy), 0) +
              " px from the image centre (> " +
              fitting::FixedOrDash(e.max_principal_offset_fraction * cameras[i].width, 0) + " px" + rig_limit +
              "): cropped images, or boards that never reached the image's edges");
  }
  const double f_ratio = cameras[0].params[0] / cameras[1].params[0];
  if (std::abs(f_ratio - 1) > e.max_focal_mismatch)
    add("focal",
        false,
        "the two eyes' focal lengths differ by " + fitting::FixedOrDash(100 * std::abs(f_ratio - 1), 1) + " % (left " +
            fitting::FixedOrDash(cameras[0].params[0], 1) + ", right " + fitting::FixedOrDash(cameras[1].params[0], 1) +
            " px): the same lens on both eyes should agree within " +
            fitting::FixedOrDash(100 * e.max_focal_mismatch, 0) + " % (the " + e.name +
            " rig's limit); one eye's f is not determined by the set, or the eyes have different lenses or image "
            "sizes");
  return s;
}

std::string WhyNotThisRig(const models::CameraIntrinsics cameras[2],
                          const models::Rigid3d& right_from_left,
                          double length_unit_m,
                          const RigExpectation& e) {
  if (!(length_unit_m > 0) || !(e.ipd_m > 0) || !(e.focal_max_px > 0)) return "";
  const double b = right_from_left.translation.norm() * length_unit_m;
  if (!(std::abs(b - e.ipd_m) > e.ipd_tolerance_m)) return "";
  std::string lens;
  const char* eye[2] = {"left", "right"};
  for (int i = 0; i < 2 && lens.empty(); ++i) {
    const double scale = cameras[i].width / e.reference_width_px, f = cameras[i].params[0];
    if (f < e.focal_min_px * scale || f > e.focal_max_px * scale)
      lens = std::string(eye[i]) + " eye f = " + fitting::FixedOrDash(f, 1) + " px, outside the " + e.name +
             " lens family (" + fitting::FixedOrDash(e.focal_min_px * scale, 0) + "-" +
             fitting::FixedOrDash(e.focal_max_px * scale, 0) + " px at " + std::to_string(cameras[i].width) +
             " px wide)";
  }
  if (lens.empty()) return "";
  return "baseline " + fitting::FixedOrDash(b * 1000, 1) + " mm, not the " + e.name + " rig's " +
         fitting::FixedOrDash(e.ipd_m * 1000, 1) + " +- " + fitting::FixedOrDash(e.ipd_tolerance_m * 1000, 1) +
         " mm; " + lens;
}

void AppendSanityToResult(const StereoSanity& s, const RigExpectation& e, fitting::CalibrationResult* r) {
  nlohmann::json f = nlohmann::json::array();
  for (const auto& x : s.findings) {
    f.push_back({{"check", x.check}, {"severity", x.unusable ? "unusable" : "poor"}, {"message", x.message}});
    r->warnings.push_back("sanity: " + x.message);
  }
  r->diagnostics["sanity"] = {
      {"rig", e.name}, {"ok", s.ok()}, {"mirrored_or_swapped", s.mirrored_or_swapped}, {"findings", f}};
}

}  // namespace owlcal::evaluation
