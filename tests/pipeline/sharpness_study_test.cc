// The lens-sharpness experiment end to end: the standard sharpness protocol recorded on the
// in-process virtual Owl (the default robot and the worn variant A, whose lens is focused
// nearer), evaluated as `owlcal sharpness` evaluates it: the fitted focus and defocus per eye
// against the robot's truth (aperture 1.25 mm and focus 0.56 m on the default robot, from the
// course notes' Annex 3a); a lens without defocus yields no focus (and says so); and the real
// kit2020 distance set gives a blur-vs-distance curve with the course lens's defocus.
#include "pipeline/sharpness_study.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "owlcal_version.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "reports/sharpness_study_page.h"
#include "sim/robot_truth.h"
#include "sim/virtual_owl.h"
#include "tests/shared_data.h"

namespace owlcal::pipeline {
namespace sharpness_study_test {
namespace fs = std::filesystem;

std::string TempDir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("owlcal_sharpness_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(p);
  return p.string();
}

evaluation::SharpnessStudy Record(const std::string& name, const sim::RobotTruth& truth) {
  sim::VirtualOwlOptions vo;
  vo.truth = truth;
  vo.seed = 3;
  sim::VirtualOwl owl(vo);
  protocols::RunOptions ro;
  ro.out_dir = TempDir(name);
  ro.robot_spec = "sim";
  ro.sim = {{"seed", 3}};  // the manifest then records the robot's truth
  const protocols::RunSummary s =
      protocols::RunProtocols({protocols::LoadProtocolFile(protocols::ResolveProtocolPath("sharpness"))}, owl, ro);
  EXPECT_EQ(s.status, "complete") << s.message;
  return MeasureSharpnessDataset(ro.out_dir);
}

// Focus and defocus per eye within 3 sigma of the truth.
void ExpectTruthRecovered(const evaluation::SharpnessStudy& s, const sim::RobotTruth& t) {
  ASSERT_TRUE(s.truth);
  EXPECT_NEAR(s.truth->focus_m, t.stream.focus_m, 1e-12);
  for (int e = 0; e < 2; ++e) {
    SCOPED_TRACE(e == 0 ? "left eye" : "right eye");
    const fitting::FocusFit& f = s.fit[e];
    ASSERT_TRUE(f.ok) << f.reason;
    ASSERT_TRUE(f.focus_found);
    const double k_true = t.stream.aperture_mm * 1e-3 * t.intrinsics[e].params[0] / 4;
    EXPECT_NEAR(s.truth->k_px_per_dioptre[e], k_true, 1e-12);
    EXPECT_LT(std::abs(f.k_px_per_dioptre - k_true), 3 * f.k_sigma) << f.k_px_per_dioptre << " +- " << f.k_sigma;
    EXPECT_LT(std::abs(f.focus_dioptre - 1 / t.stream.focus_m), 3 * f.focus_dioptre_sigma)
        << f.focus_dioptre << " +- " << f.focus_dioptre_sigma;
    // Honest, not vacuous, sigmas.
    EXPECT_LT(f.focus_dioptre_sigma, 0.3);
    EXPECT_LT(f.k_sigma, 0.03);
    // The course's "in focus from approximately 28 cm": the near limit is that of the truth's
    // lens with the fitted in-focus blur, within 3 sigma.
    double near_m, far_m;
    fitting::DepthOfField(f.s0_px, k_true, 1 / t.stream.focus_m, f.dof_blur_ratio, &near_m, &far_m);
    EXPECT_NEAR(f.dof_near_m, near_m, 3 * f.dof_near_sigma_m + 0.01);
  }
}

TEST(Sharpness, DefaultRobotFocusAndDefocusMatchTheLens) {
  const sim::RobotTruth t = sim::DefaultRobotTruth();
  const evaluation::SharpnessStudy s = Record("default", t);
  EXPECT_EQ(s.num_failed, 0);
  EXPECT_EQ(s.num_ok, 56);  // 14 distances x 2 frames x 2 eyes
  ExpectTruthRecovered(s, t);
  // Distances are from the lens: the placements less the eye's 30 mm and the camera's ~15 mm.
  EXPECT_NEAR(s.by_distance[0].front().distance_m, 0.2 - 0.0448, 0.001);
  const std::string out = TempDir("default_out");
  const std::string page = reports::WriteSharpnessStudy(s, out, false);
  EXPECT_TRUE(fs::exists(page));
  for (const char* f : {"tables/sharpness.csv",
                        "tables/sharpness_fit.md",
                        "tables/sharpness_images.csv",
                        "sharpness.json",
                        "figures/sharpness.gp",
                        "figures/sharpness.csv"})
    EXPECT_TRUE(fs::exists(out + "/" + f)) << f;
  const nlohmann::json j = evaluation::SharpnessStudyJson(s);
  EXPECT_TRUE(j["eyes"]["left"]["fit"]["focus_found"].get<bool>());
  // An infinite far limit is written as null.
  EXPECT_EQ(j["eyes"]["left"]["fit"]["dof_far_m"].is_null(), std::isinf(s.fit[0].dof_far_m));
  EXPECT_GT(s.fit[0].dof_far_m, 2.0);  // the lens is sharp to the end of the range
}

TEST(Sharpness, WornVariantWithANearerFocus) {
  const sim::RobotTruth t = sim::LoadRobotTruth(std::string(OWLCAL_SOURCE_DIR) + "/data/sim/owl_variant_a_truth.yaml");
  ASSERT_NEAR(t.stream.focus_m, 0.45, 1e-12);
  ExpectTruthRecovered(Record("variant_a", t), t);
}

TEST(Sharpness, ALensWithoutDefocusHasNoFocus) {
  sim::RobotTruth t = sim::DefaultRobotTruth();
  t.stream.aperture_mm = 0;
  const evaluation::SharpnessStudy s = Record("pinhole", t);
  EXPECT_FALSE(s.truth);  // no defocus in the truth to compare with
  for (int e = 0; e < 2; ++e) {
    ASSERT_TRUE(s.fit[e].ok) << s.fit[e].reason;
    EXPECT_FALSE(s.fit[e].focus_found) << s.fit[e].focus_dioptre << " +- " << s.fit[e].focus_dioptre_sigma;
  }
  bool said = false;
  for (const std::string& n : s.notes) said |= n.find("the focus distance is not determined") != std::string::npos;
  EXPECT_TRUE(said);
}

TEST(Sharpness, RealKitDistanceSetShowsTheCourseLens) {
  const std::string csv = test_data::SharedData() + "/owl-real/kit2020-distance-target1/distances.csv";
  const evaluation::SharpnessStudy s = MeasureSharpnessPairs(ReadSharpnessPairsCsv(csv), csv);
  EXPECT_EQ(s.rows.size(), 26u);
  EXPECT_GE(s.num_ok, 24);
  // Every failure is a row with a reason, and named in the notes.
  for (const evaluation::SharpnessRow& r : s.rows) {
    if (r.status != "ok") {
      EXPECT_FALSE(r.reason.empty()) << r.image;
    }
  }
  EXPECT_GE(int(s.notes.size()), s.num_failed);
  // The left eye: sharpest in the middle of the range, blurred at 30 cm.
  const fitting::FocusFit& f = s.fit[0];
  ASSERT_TRUE(f.ok) << f.reason;
  ASSERT_TRUE(f.focus_found);
  EXPECT_GT(s.by_distance[0].front().sigma_px, 1.4 * f.s0_px);
  EXPECT_GT(f.focus_m, 0.4);
  EXPECT_LT(f.focus_m, 1.0);
  // The course's lens (1.25 mm pupil, ~600 px focal length at 640 x 480): 0.19 px per dioptre.
  EXPECT_NEAR(f.k_px_per_dioptre, 1.25e-3 * 600 / 4, 3 * f.k_sigma);
  EXPECT_LT(f.s0_px, 0.35);  // a real Owl's edges are sharp: ~0.25 px in focus
}

TEST(Sharpness, BadInputIsNamed) {
  const std::string dir = TempDir("bad");
  fs::create_directories(dir);
  std::ofstream(dir + "/pairs.csv") << "left,right,distance_cm\nl.jpg,r.jpg,\n";
  try {
    ReadSharpnessPairsCsv(dir + "/pairs.csv");
    FAIL() << "a blank distance was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("pairs.csv:2"), std::string::npos) << e.what();
  }
  std::ofstream(dir + "/pairs.csv") << "left,right,distance_cm\nmissing_l.jpg,missing_r.jpg,50\n";
  const evaluation::SharpnessStudy s = MeasureSharpnessPairs(ReadSharpnessPairsCsv(dir + "/pairs.csv"), dir);
  ASSERT_EQ(s.rows.size(), 2u);
  EXPECT_EQ(s.rows[0].status, "unreadable");
  EXPECT_EQ(s.num_failed, 2);
  EXPECT_FALSE(s.fit[0].ok);
}

}  // namespace sharpness_study_test
}  // namespace owlcal::pipeline
