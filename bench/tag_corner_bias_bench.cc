// Where calib's AprilTag detector puts the tag sheets' corners against the virtual Owl's truth,
// as a function of the tag's size in the image and the optical blur (issue 17): one tag sheet
// (sim/scene.cc TagSheetDefinition, 45 mm tags) on or off the left eye's optical axis at the
// centre pose, rendered at distances 0.35-1.1 m and blur_px 1.0-2.2 (the prior's range), detected
// by calib::DetectTarget, every corner compared with its projection through the truth.
// Per row: the tag's size [px]; the border offset (detected minus true along the tag's outward
// diagonal, in mm on the sheet and in px: > 0 when the detected quad is larger than the printed
// black square) with its standard error and the corners' RMS; the corners' mean radius from the
// principal point and their offset away from it, against the projection, as the straight-edge
// model predicts it (fitting/tag_edge_corner.h, through the TRUE lens) and against that model.
//
// Measured at this commit (noise 0, no JPEG; with noise 2 and JPEG 80 the same within 0.003 px):
// - default lens on axis, 0.7 m (37 px tags): border offset +0.002 / +0.0003 / +0.003 px at blur
//   1.0 / 1.6 / 2.2; it grows for small tags and wide blur (24 px tags at blur 2.2: +0.046 px).
// - prior-1's wide lens (f 489 px, k1 -0.216), 200-330 px off axis: the detector's corners lie
//   0.02-0.09 px farther from the principal point than their projections, and the straight-edge
//   model (true lens) predicts that within 0.001-0.005 px; lens shading (0.33) moves it 0.001 px.
//
// Usage: tag_corner_bias_bench [noise_sigma=0] [jpeg_quality=0 (none)]
// Environment: TAG_BIAS_TRUTH=robot truth yaml (default data/sim/owl_default_truth.yaml),
// TAG_BIAS_OFF=t (sheet centre at (t z, 0.75 t z, z) in the camera frame, default 0),
// TAG_BIAS_SHADING=1 keeps the truth's lens shading (default none), TAG_BIAS_NO_DEFOCUS=1.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "calib/detector.h"
#include "fitting/tag_edge_corner.h"
#include "owlcal_version.h"
#include "sim/scene.h"
#include "sim/virtual_owl.h"

int main(int argc, char** argv) {
  using namespace owlcal;
  const double noise = argc > 1 ? std::atof(argv[1]) : 0.0;
  const int jpeg = argc > 2 ? std::atoi(argv[2]) : 0;
  const bool no_defocus = std::getenv("TAG_BIAS_NO_DEFOCUS") != nullptr;
  const char* sheet_name = "tags_right_up";
  std::printf("noise %.1f, jpeg %d%s\n", noise, jpeg, no_defocus ? ", no defocus" : "");
  std::printf(
      "| blur_px | distance m | tag px | corners | border offset mm | px | s.e. px | RMS px "
      "|\n|---|---|---|---|---|---|---|---|\n");
  for (double blur : {1.0, 1.6, 2.2}) {
    for (double z : {0.35, 0.5, 0.7, 0.9, 1.1}) {
      sim::VirtualOwlOptions o;
      o.seed = 5;
      const char* truth_file = std::getenv("TAG_BIAS_TRUTH");
      sim::RobotTruth truth = sim::LoadRobotTruth(
          truth_file ? truth_file : std::string(OWLCAL_SOURCE_DIR) + "/data/sim/owl_default_truth.yaml");
      truth.stream.blur_px = blur;
      if (!std::getenv("TAG_BIAS_SHADING")) truth.stream.lens_shading = 0;
      if (no_defocus) truth.stream.aperture_mm = 0;
      o.truth = truth;
      o.noise_sigma = noise;
      o.encode_jpeg = jpeg > 0;
      if (jpeg > 0) o.jpeg_quality = jpeg;
      sim::VirtualOwl owl(o);
      for (const std::string& n : owl.TargetNames())
        if (n != sheet_name) owl.SetTargetVisible(n, false);
      owl.SendServos(owl.Config().Centre());
      owl.SleepNs(1'000'000'000);
      auto first = owl.GrabFrame(owl.NowNs(), 1'000'000'000);
      const sim::FrameTruth ft0 = owl.TruthForFrame(first->seq);
      const calib::TargetDefinition def = owl.SceneState().Find(sheet_name)->definition;
      // The sheet's centre on the left camera's optical axis, facing the robot.
      const models::Rigid3d base_from_cam = ft0.cam_from_base[models::kLeftEye].Inverse();
      const double off =
          std::getenv("TAG_BIAS_OFF") ? std::atof(std::getenv("TAG_BIAS_OFF")) : 0.0;  // tan of the angle off axis
      const Eigen::Vector3d centre = base_from_cam * Eigen::Vector3d(off * z, 0.75 * off * z, z);
      double rad_proj = 0, rad_edge = 0, rad_model = 0, r_px = 0;
      double sum = 0, sum2 = 0, sum_px = 0, sum2_px = 0, ss = 0, size_px = 0;
      int n = 0, nt = 0;
      int64_t after = first->stamp_ns;
      for (int rep = 0; rep < 4; ++rep) {
        // Small shifts and turns so the corners sample the pixel grid's phases.
        const Eigen::Isometry3d pose = sim::FacingPose(
            def, centre + Eigen::Vector3d(0.003 * rep, 0.002 * rep, 0), 3.0 * rep - 4, 2.0 - rep, 5.0 * rep);
        owl.SetTargetPose(sheet_name, pose);
        owl.SleepNs(100'000'000);
        auto frame = owl.GrabFrame(after, 1'000'000'000);
        after = frame->stamp_ns;
        const sim::FrameTruth ft = owl.TruthForFrame(frame->seq);
        const models::HeadModel head = owl.TruthHeadModel();
        const auto& cam = head.intrinsics[models::kLeftEye];
        auto project = [&](const Eigen::Vector3d& x, Eigen::Vector2d* px) {
          const Eigen::Vector3d p = ft.cam_from_base[models::kLeftEye] * (pose * x);
          return cam.Project(p.data(), px->data());
        };
        const calib::TargetDetection d = calib::DetectTarget(frame->left, def, calib::DetectorOptions());
        if (!d.found) continue;
        const auto corners = def.Corners();
        for (size_t k = 0; k < d.pixels.size(); ++k) {
          const int id = d.corner_ids[k], c = id % 4;
          const Eigen::Vector3d x = corners.at(id);
          const double half = def.tag_size_m / 2;
          const Eigen::Vector3d sign(c == 0 || c == 3 ? -1 : 1, c < 2 ? -1 : 1, 0);
          Eigen::Vector2d px, pc;
          if (!project(x, &px) || !project(x - half * sign, &pc)) continue;
          const Eigen::Vector2d out = px - pc;
          const double along = (d.pixels[k] - px).dot(out.normalized());
          const double mm = along / out.norm() * half * 1000;
          sum += mm, sum2 += mm * mm, sum_px += along, sum2_px += along * along;
          ss += (d.pixels[k] - px).squaredNorm();
          const auto edge = fitting::TagEdgeCornerPixel(project, fitting::TagCornersOf(x, id, def.tag_size_m), c);
          const Eigen::Vector2d pp(cam.params[2], cam.params[3]);
          const Eigen::Vector2d radial = (px - pp).normalized();
          rad_proj += (d.pixels[k] - px).dot(radial);
          if (edge) rad_edge += (d.pixels[k] - *edge).dot(radial), rad_model += (*edge - px).dot(radial);
          r_px += (px - pp).norm();
          size_px += out.norm() * std::sqrt(2.0);
          ++n;
        }
        ++nt;
      }
      if (n == 0) {
        std::printf("| %.1f | %.2f | - | 0 | - | - | - | - |\n", blur, z);
        continue;
      }
      const double m = sum / n, mp = sum_px / n;
      const double sdp = std::sqrt(std::max(0.0, sum2_px / n - mp * mp));
      std::printf(
          "| %.1f | %.2f | %.1f | %d | %+.4f | %+.4f | %.4f | %.4f | r %.0f px: radial vs projection %+.4f, model "
          "%+.4f, vs model %+.4f |\n",
          blur,
          z,
          size_px / n,
          n,
          m,
          mp,
          sdp / std::sqrt(n),
          std::sqrt(ss / n),
          r_px / n,
          rad_proj / n,
          rad_model / n,
          rad_edge / n);
      std::fflush(stdout);
    }
  }
  return 0;
}
