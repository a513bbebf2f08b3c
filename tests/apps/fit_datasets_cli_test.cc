// Everything downstream of a recorded dataset runs without the robot: `owlcal fit-datasets` on a
// folder `owlcal calibrate` wrote gives every results.json parameter the same value and sigma
// (bit for bit), records its options and the software in inputs, and other options change the fit.
// A small run: the stereo protocol and a short servo sweep (tests/data/protocols).
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "calib/observation_io.h"
#include "fitting/robot_config_json.h"
#include "owlcal_version.h"
#include "protocols/dataset.h"
#include "tests/apps/run_owlcal.h"

namespace owlcal {
namespace fit_datasets_cli_test {

namespace fs = std::filesystem;
using test_cli::RunOwlcal;

nlohmann::json ReadJson(const fs::path& p) {
  std::ifstream f(p);
  return nlohmann::json::parse(f);
}

// name -> {value, sigma} of results.json's parameters.
std::map<std::string, nlohmann::json> Parameters(const nlohmann::json& results) {
  std::map<std::string, nlohmann::json> out;
  for (const auto& p : results.at("parameters")) out[p.at("name").get<std::string>()] = p;
  return out;
}

TEST(FitDatasetsCli, ARefitOfACalibrateFolderReproducesEveryValueAndSigma) {
  ASSERT_FALSE(test_cli::OwlcalBinary().empty()) << "the owlcal binary is not built";
  const fs::path root = fs::temp_directory_path() / ("owlcal_fit_datasets_" + std::to_string(::getpid()));
  fs::remove_all(root);
  const std::string sweep = std::string(OWLCAL_SOURCE_DIR) + "/tests/data/protocols/servo_sweep_small.yaml";
  const auto cal = RunOwlcal("calibrate --quiet --no-figures --protocols stereo '" + sweep + "' --out '" +
                             (root / "cal").string() + "'");
  ASSERT_EQ(cal.exit_code, 0) << cal.output;
  const auto refit = RunOwlcal("fit-datasets '" + (root / "cal").string() + "' --quiet --no-figures --out '" +
                               (root / "refit").string() + "'");
  ASSERT_EQ(refit.exit_code, 0) << refit.output;

  const nlohmann::json a = ReadJson(root / "cal" / "results.json");
  const nlohmann::json b = ReadJson(root / "refit" / "results.json");
  const auto pa = Parameters(a), pb = Parameters(b);
  // The run fitted the stereo rig and the head (else there is little to reproduce).
  ASSERT_TRUE(pa.count("head.ipd_mm")) << a.dump(1).substr(0, 2000);
  ASSERT_TRUE(pa.count("stereo.tx")) << a.dump(1).substr(0, 2000);
  ASSERT_GT(pa.size(), 40u);
  ASSERT_EQ(pa.size(), pb.size());
  int with_sigma = 0;
  for (const auto& [name, p] : pa) {
    ASSERT_TRUE(pb.count(name)) << name;
    EXPECT_EQ(p.at("value"), pb.at(name).at("value")) << name;
    EXPECT_EQ(p.value("sigma", nlohmann::json()), pb.at(name).value("sigma", nlohmann::json())) << name;
    EXPECT_EQ(p.value("truth", nlohmann::json()), pb.at(name).value("truth", nlohmann::json())) << name;
    with_sigma += p.contains("sigma") && p.at("sigma").is_number();
  }
  EXPECT_GT(with_sigma, 30);
  for (const char* block : {"head", "stereo", "cameras"}) EXPECT_EQ(a.at(block), b.at(block)) << block;
  EXPECT_EQ(a.at("warnings"), b.at("warnings"));
  // Inputs: the same pipeline options, the software with its commit, the command and its options.
  EXPECT_EQ(a.at("inputs").at("pipeline"), b.at("inputs").at("pipeline"));
  EXPECT_EQ(a.at("inputs").at("datasets"), b.at("inputs").at("datasets"));
  EXPECT_FALSE(a.at("inputs").at("software").at("git").get<std::string>().empty());
  EXPECT_EQ(a.at("inputs").at("command").at("command"), "owlcal calibrate");
  EXPECT_EQ(b.at("inputs").at("command").at("command"), "owlcal fit-datasets");
  EXPECT_EQ(b.at("inputs").at("command").at("sigma_factor"), 1.4);
  EXPECT_EQ(a.at("inputs").at("pipeline").at("head").at("measured_sigma_factor"), 1.4);
  EXPECT_TRUE(fs::exists(root / "refit" / "calibration.yaml"));
  EXPECT_TRUE(fs::exists(root / "refit" / "report" / "index.html"));

  // detect re-detects a dataset's recorded frames, each corner keeping its frame's command.
  const fs::path stereo = root / "cal" / "datasets" / "stereo";
  const auto det =
      RunOwlcal("detect '" + stereo.string() + "' --target '" + std::string(OWLCAL_SOURCE_DIR) +
                "/data/targets/owl-kit-chessboard.yaml' --out '" + (root / "redetected.csv").string() + "'");
  ASSERT_EQ(det.exit_code, 0) << det.output;
  const auto recorded = calib::ReadObservationsCsv((stereo / "observations.csv").string());
  const auto redetected = calib::ReadObservationsCsv((root / "redetected.csv").string());
  ASSERT_EQ(redetected.size(), recorded.size());
  for (size_t i = 0; i < recorded.size(); ++i) {
    EXPECT_EQ(redetected[i].frame_index, recorded[i].frame_index) << i;
    EXPECT_EQ(redetected[i].eye, recorded[i].eye) << i;
    EXPECT_EQ(redetected[i].corner_id, recorded[i].corner_id) << i;
    EXPECT_EQ(redetected[i].pwm_us, recorded[i].pwm_us) << i;
    EXPECT_EQ(redetected[i].approach, recorded[i].approach) << i;
    EXPECT_EQ(redetected[i].stamp_ns, recorded[i].stamp_ns) << i;
    EXPECT_LT((redetected[i].pixel - recorded[i].pixel).norm(), 0.05) << i;
  }

  // Other options: another fit, and results.json says which.
  const auto held = RunOwlcal("fit-datasets '" + (root / "cal").string() +
                              "' --quiet --no-figures --sigma-factor 1 --out '" + (root / "held").string() + "'");
  ASSERT_EQ(held.exit_code, 0) << held.output;
  const nlohmann::json c = ReadJson(root / "held" / "results.json");
  EXPECT_EQ(c.at("inputs").at("pipeline").at("head").at("measured_sigma_factor"), 1.0);
  const auto pc = Parameters(c);
  EXPECT_NE(pc.at("head.ipd_mm").at("sigma"), pa.at("head.ipd_mm").at("sigma"));
  // The output folder is never overwritten.
  const auto again =
      RunOwlcal("fit-datasets '" + (root / "cal").string() + "' --quiet --out '" + (root / "refit").string() + "'");
  EXPECT_EQ(again.exit_code, 2) << again.output;
  fs::remove_all(root);
}

TEST(FitDatasetsCli, AFolderWithoutDatasetsIsAClearError) {
  ASSERT_FALSE(test_cli::OwlcalBinary().empty()) << "the owlcal binary is not built";
  const fs::path root = fs::temp_directory_path() / ("owlcal_fit_datasets_empty_" + std::to_string(::getpid()));
  fs::remove_all(root);
  fs::create_directories(root / "datasets");
  const auto r = RunOwlcal("fit-datasets '" + root.string() + "' --quiet --out '" + (root / "out").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("holds no dataset"), std::string::npos) << r.output;
  fs::remove_all(root);
}

std::string Slurp(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// Regression: a dataset whose manifest names an unknown protocol was skipped with only a progress
// line (nothing with --quiet, nothing in results.json). Now it is a warning on stderr with --quiet,
// in results.json's warnings and in the report. The output folder held an earlier run's
// calibration.yaml and ROS export (but no results.json, so fit-datasets may write there): this run
// writes no calibration.yaml (it fits no stereo rig), and the earlier one must not look current.
TEST(FitDatasetsCli, ADatasetOfAnUnknownProtocolIsAWarningEvenWhenQuiet) {
  ASSERT_FALSE(test_cli::OwlcalBinary().empty()) << "the owlcal binary is not built";
  const fs::path root = fs::temp_directory_path() / ("owlcal_fit_datasets_unknown_" + std::to_string(::getpid()));
  fs::remove_all(root);
  const nlohmann::json manifest = {{"protocols", {{{"name", "intrinsicz"}}}},
                                   {"robot", {{"config", fitting::RobotConfigToJson(models::DefaultRobotConfig())}}}};
  protocols::DatasetWriter::Create((root / "datasets" / "intrinsics").string(), manifest)->Finish("complete", "");
  const fs::path out = root / "out";
  fs::create_directories(out / "exports");
  std::ofstream(out / "calibration.yaml") << "%YAML:1.0\n---\nowlcal_run_id: \"earlier\"\n";
  std::ofstream(out / "exports" / "ros_left.yaml") << "# stale\nimage_width: 640\n";
  const auto r = RunOwlcal("fit-datasets '" + root.string() + "' --quiet --no-figures --out '" + out.string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string dataset = (root / "datasets" / "intrinsics").string();
  EXPECT_NE(r.output.find("warning: dataset " + dataset + " skipped: its manifest names protocol 'intrinsicz'"),
            std::string::npos)
      << r.output;
  const nlohmann::json results = ReadJson(out / "results.json");
  ASSERT_FALSE(results.at("warnings").empty());
  EXPECT_NE(results.at("warnings")[0].get<std::string>().find("protocol 'intrinsicz'"), std::string::npos)
      << results.at("warnings");
  EXPECT_NE(Slurp(out / "report" / "index.html").find("protocol 'intrinsicz'"), std::string::npos);
  // The earlier run's files are gone; this run's carry one run id.
  EXPECT_FALSE(fs::exists(out / "calibration.yaml"));
  EXPECT_EQ(Slurp(out / "exports" / "ros_left.yaml").find("# stale"), std::string::npos);
  const std::string id = results.value("run_id", "");
  EXPECT_FALSE(id.empty());
  EXPECT_EQ(ReadJson(out / "evaluation.json").value("run_id", ""), id);
  EXPECT_EQ(ReadJson(out / "exports" / "owlcal_run.json").value("run_id", ""), id);
  fs::remove_all(root);
}

}  // namespace fit_datasets_cli_test
}  // namespace owlcal
