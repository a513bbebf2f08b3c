// --rig auto (evaluation/set_verdict.h recognise_rig) on the repository's real sets: OpenCV's
// stereo sample given a metric square size (25 mm, what its calibration sample was run with) is
// plainly no Owl (baseline about 83 mm, f about 533 px), so it is said once and judged as a
// generic pair, as it is in squares; judged against the Owl it is "poor" for rig reasons that
// name the rig. An Owl set (kit2020-chessboard) stays an Owl.
#include <iostream>
#include <string>

#include <gtest/gtest.h>

#include "calib/image_pairs.h"
#include "evaluation/range_images_calib.h"
#include "reports/verdict_tables.h"
#include "tests/shared_data.h"

namespace owlcal::fitting {
namespace {

using ::owlcal::test_data::SharedData;

evaluation::ImageSetCalibration Calibrate(const std::string& dir,
                                          double square,
                                          const std::string& unit,
                                          bool recognise,
                                          const evaluation::RigExpectation& rig,
                                          size_t max_pairs) {
  calib::TargetDefinition board;
  board.cols = 9;
  board.rows = 6;
  board.square_m = square;
  auto list = calib::ListImagePairs(SharedData() + "/" + dir, {});
  if (list.pairs.size() > max_pairs) list.pairs.resize(max_pairs);
  const auto set = calib::DetectImagePairs(list, {}, board, calib::DetectorOptions());
  StereoFitOptions o;
  o.width = set.width;
  o.height = set.height;
  o.length_unit = unit;
  evaluation::SetVerdictOptions vo;
  vo.rig = rig;
  vo.recognise_rig = recognise;
  return evaluation::CalibrateImageSet(set.observations, o, vo);
}

bool AnyMentions(const std::vector<std::string>& reasons, const std::string& what) {
  for (const auto& r : reasons)
    if (r.find(what) != std::string::npos) return true;
  return false;
}

TEST(RigRecognitionReal, OpenCvSampleInMetresIsRecognisedAsNoOwlAndJudgedAsAGenericPair) {
  const std::string dir = "opencv-stereo-chessboard";
  const evaluation::ImageSetCalibration squares =
      Calibrate(dir, 1.0, "square", false, evaluation::RigExpectation::Generic(), 13);
  const evaluation::ImageSetCalibration autod = Calibrate(dir, 0.025, "m", true, evaluation::RigExpectation::Owl(), 13);
  const evaluation::ImageSetCalibration owl = Calibrate(dir, 0.025, "m", false, evaluation::RigExpectation::Owl(), 13);
  ASSERT_TRUE(autod.fit.ok) << autod.fit.message;
  std::cout << "auto:\n"
            << reports::SetVerdictMarkdown(autod.set_verdict) << "\nowl:\n"
            << reports::SetVerdictMarkdown(owl.set_verdict);
  // Said once, with both signs, and the flag that judges it as an Owl anyway.
  EXPECT_EQ(autod.set_verdict.rig.name, "generic");
  const std::string& note = autod.set_verdict.rig_note;
  EXPECT_NE(note.find("not an owl"), std::string::npos) << note;
  EXPECT_NE(note.find("baseline"), std::string::npos) << note;
  EXPECT_NE(note.find("lens family"), std::string::npos) << note;
  EXPECT_NE(note.find("--rig owl"), std::string::npos) << note;
  EXPECT_FALSE(AnyMentions(autod.set_verdict.reasons, "owl")) << autod.set_verdict.reasons.size();
  EXPECT_EQ(autod.result.verdict.at("rig"), "generic");
  // The same verdict as the set in squares (a generic pair with no baseline check).
  EXPECT_EQ(autod.set_verdict.status, squares.set_verdict.status);
  EXPECT_NE(autod.set_verdict.status, "unusable");
  // Against the Owl (--rig owl, and what auto did before): poor, for reasons naming the rig.
  EXPECT_EQ(owl.set_verdict.status, "poor");
  EXPECT_TRUE(owl.set_verdict.rig_note.empty());
  EXPECT_TRUE(AnyMentions(owl.set_verdict.reasons, "owl rig's IPD"));
  EXPECT_TRUE(AnyMentions(owl.set_verdict.reasons, "owl lens family"));
  for (const auto& f : owl.set_verdict.sanity.findings) {
    if (f.check != "tx_sign") {
      EXPECT_NE(f.message.find("owl"), std::string::npos) << f.message;
    }
  }
}

TEST(RigRecognitionReal, AnOwlSetStaysAnOwl) {
  const evaluation::ImageSetCalibration c =
      Calibrate("owl-real/kit2020-chessboard", 0.026, "m", true, evaluation::RigExpectation::Owl(), 14);
  ASSERT_TRUE(c.fit.ok) << c.fit.message;
  EXPECT_EQ(c.set_verdict.rig.name, "owl");
  EXPECT_TRUE(c.set_verdict.rig_note.empty()) << c.set_verdict.rig_note;
  EXPECT_NE(reports::SetVerdictMarkdown(c.set_verdict).find("Rig: owl"), std::string::npos);
}

}  // namespace
}  // namespace owlcal::fitting
