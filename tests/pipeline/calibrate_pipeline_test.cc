// The calibration pipeline's own contract: which datasets a calibrate folder holds, the robot a
// manifest recorded, options that are checked and recorded, and datasets with nothing to fit.
#include "pipeline/calibrate_pipeline.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>

#include <gtest/gtest.h>

#include "fitting/robot_config_json.h"
#include "protocols/dataset.h"

namespace owlcal::pipeline {
namespace {
namespace fs = std::filesystem;

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(no error)";
}

fs::path TempDir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("owlcal_pipeline_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(p);
  fs::create_directories(p / "datasets");
  return p;
}

void MakeDataset(const fs::path& dir, const std::string& protocol) {
  protocols::DatasetWriter::Create(dir.string(), {{"protocols", {{{"name", protocol}}}}})->Finish("complete", "");
}

TEST(CalibratePipeline, FindsTheDatasetsOfACalibrateFolderByProtocol) {
  const fs::path root = TempDir("find");
  EXPECT_NE(ErrorOf([&] { FindDatasets(root.string()); }).find("holds no dataset"), std::string::npos);
  MakeDataset(root / "datasets" / "stereo", "stereo");
  MakeDataset(root / "datasets" / "my_sweep", "servo_sweep");
  fs::create_directories(root / "datasets" / "notes");  // no manifest: not a dataset
  const auto d = FindDatasets(root.string());
  ASSERT_EQ(d.size(), 2u);
  EXPECT_EQ(d.at("servo_sweep"), (root / "datasets" / "my_sweep").string());
  EXPECT_EQ(d.at("stereo"), (root / "datasets" / "stereo").string());
  MakeDataset(root / "datasets" / "stereo2", "stereo");
  EXPECT_NE(ErrorOf([&] { FindDatasets(root.string()); }).find("a second dataset of protocol 'stereo'"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] { FindDatasets((root / "datasets").string()); }).find("not a calibrate output folder"),
            std::string::npos);
  fs::remove_all(root);
}

TEST(CalibratePipeline, TheRobotComesFromTheManifest) {
  models::RobotConfig c = models::DefaultRobotConfig();
  c.name = "bench-owl";
  c.servos[models::kNeck].max_us = 1900;
  c.swap_eyes = true;
  const nlohmann::json m = {{"robot", {{"config", fitting::RobotConfigToJson(c)}}}};
  const models::RobotConfig r = RobotConfigFromManifest(m, "m.json");
  EXPECT_EQ(r.name, "bench-owl");
  EXPECT_EQ(r.servos[models::kNeck].max_us, 1900);
  EXPECT_TRUE(r.swap_eyes);
  EXPECT_EQ(fitting::RobotConfigToJson(r), fitting::RobotConfigToJson(c));
  EXPECT_EQ(ErrorOf([] { RobotConfigFromManifest(nlohmann::json::object(), "m.json"); }),
            "m.json: field 'robot.config' is missing");
}

TEST(CalibratePipeline, OptionsAreCheckedAndRecorded) {
  CalibratePipelineOptions o;
  std::string why;
  EXPECT_TRUE(o.Check(&why)) << why;
  EXPECT_TRUE(o.head.fit_intrinsics);
  EXPECT_EQ(o.head.measured_sigma_factor, 1.4);
  const nlohmann::json j = o.ToJson();
  EXPECT_EQ(j.at("head").at("measured_sigma_factor"), 1.4);
  // The head's sigma from the residuals clustered by 100 us cells, the stereo fit's intrinsics
  // floor carried to the servo maps, no hysteresis floor (pipeline/calibrate_pipeline.cc says why).
  EXPECT_EQ(j.at("head").at("covariance_clusters"), "cell:100");
  EXPECT_EQ(j.at("head").at("robust_sigma_factor"), 1.0);
  EXPECT_EQ(j.at("head").at("intrinsics_floor_carry"), "servo_maps");
  EXPECT_EQ(j.at("head").at("pan_zero_sigma_factor"), 1.25);
  EXPECT_EQ(j.at("head").at("hysteresis_sigma_floor_us"), 0.0);
  EXPECT_EQ(j.at("stereo").at("intrinsics").at("model"), "opencv5");
  EXPECT_EQ(j.at("truth"), false);
  // The head result fuses the tag sheets, with the chessboard's knowledge of the focal scale,
  // principal points and pan zero and 0.4 x the stereo fit's intrinsics floor.
  EXPECT_EQ(j.at("fuse_tags"), true);
  EXPECT_EQ(j.at("fused_floor_scale"), 0.4);
  EXPECT_EQ(j.at("fused_pinhole_floor"), true);
  EXPECT_EQ(j.at("fused_pan_zero_floor"), true);
  for (double bad : {-0.5, 11.0, std::nan("")}) {
    CalibratePipelineOptions b;
    b.fused_floor_scale = bad;
    EXPECT_FALSE(b.Check(&why)) << bad;
    EXPECT_NE(why.find("fused_floor_scale"), std::string::npos) << why;
  }
  o.fps = 0;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("fps"), std::string::npos);
  EXPECT_THROW(CalibrateFromDatasets({}, o), std::invalid_argument);
}

TEST(CalibratePipeline, NoDatasetsGiveWarningsNotACrash) {
  const evaluation::CalibrationRun run = CalibrateFromDatasets({}, CalibratePipelineOptions());
  ASSERT_GE(run.result.warnings.size(), 2u);
  EXPECT_EQ(run.result.warnings[0], "no chessboard views: intrinsics and stereo not fitted");
  EXPECT_NE(run.result.warnings[1].find("no head fit"), std::string::npos);
  EXPECT_TRUE(run.result.head.has_value());
  EXPECT_FALSE(run.ranging);
  EXPECT_TRUE(run.result.inputs.contains("pipeline"));
}

// Regression: fit-datasets skipped a dataset whose manifest named an unknown protocol with only a
// progress line (none with --quiet), so a renamed intrinsics dataset silently tripled left.fx's
// sigma. The skip is the first warning of the result and goes to the warning callback.
TEST(CalibratePipeline, ADatasetOfAnUnknownProtocolIsAWarning) {
  const fs::path root = TempDir("unknown");
  MakeDataset(root / "datasets" / "intrinsics", "intrinsicz");
  CalibratePipelineOptions o;
  std::vector<std::string> said, progress;
  o.warning = [&](const std::string& w) { said.push_back(w); };
  o.progress = [&](const std::string& m) { progress.push_back(m); };
  const std::string dir = (root / "datasets" / "intrinsics").string();
  const evaluation::CalibrationRun run = CalibrateFromDatasets({{"intrinsicz", dir}}, o);
  ASSERT_FALSE(run.result.warnings.empty());
  const std::string& w = run.result.warnings[0];
  EXPECT_NE(w.find("dataset " + dir + " skipped"), std::string::npos) << w;
  EXPECT_NE(w.find("protocol 'intrinsicz'"), std::string::npos) << w;
  EXPECT_NE(w.find("known: "), std::string::npos) << w;
  ASSERT_EQ(said.size(), 1u);
  EXPECT_EQ(said[0], w);
  for (const auto& m : progress) EXPECT_EQ(m.find("intrinsicz"), std::string::npos) << "said twice: " << m;
  fs::remove_all(root);
}

}  // namespace
}  // namespace owlcal::pipeline
