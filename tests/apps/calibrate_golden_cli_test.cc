// `owlcal calibrate` on a fixed seed against the results recorded in
// tests/data/golden/calibrate_small.json, parameter by parameter: every fitted value and sigma,
// the ranging rows and the warnings. A change that moves a number fails here and must say why in
// its commit; then regenerate the file with OWLCAL_UPDATE_GOLDEN=1 (this test writes it) and
// commit it with the change. The tolerance (1e-4 sigma, 1e-9 relative without a sigma) is far
// below any real change and above the rounding of another optimisation level.
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "owlcal_version.h"
#include "tests/apps/run_owlcal.h"

namespace owlcal {
namespace {

namespace fs = std::filesystem;
using test_cli::RunOwlcal;

const std::string kGolden = std::string(OWLCAL_SOURCE_DIR) + "/tests/data/golden/calibrate_small.json";
const std::string kProtocols = std::string(OWLCAL_SOURCE_DIR) + "/tests/data/protocols/";

// What the golden file keeps of a results.json and its evaluation.json.
nlohmann::json Digest(const fs::path& cal) {
  std::ifstream rf(cal / "results.json"), ef(cal / "evaluation.json");
  const nlohmann::json r = nlohmann::json::parse(rf), e = nlohmann::json::parse(ef);
  nlohmann::json params = nlohmann::json::object();
  for (const auto& p : r.at("parameters"))
    params[p.at("name").get<std::string>()] = {{"value", p.at("value")}, {"sigma", p.value("sigma", nlohmann::json())}};
  nlohmann::json ranging = nlohmann::json::array();
  if (e.contains("ranging") && e["ranging"].contains("rows"))
    for (const auto& row : e["ranging"]["rows"])
      ranging.push_back({{"status", row.value("status", "")}, {"range_m", row.value("range_m", nlohmann::json())}});
  return {{"parameters", params}, {"ranging", ranging}, {"warnings", r.at("warnings")}};
}

// One fixed-seed run, shared by the tests below.
class CalibrateGolden : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = fs::temp_directory_path() / ("owlcal_golden_" + std::to_string(::getpid()));
    fs::remove_all(root_);
    const auto cal = RunOwlcal("calibrate --quiet --no-figures --seed 3 --protocols " + kRunProtocols + " --out '" +
                               (root_ / "cal").string() + "'");
    exit_code_ = cal.exit_code;
    output_ = cal.output;
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }
  void SetUp() override {
    ASSERT_FALSE(test_cli::OwlcalBinary().empty()) << "the owlcal binary is not built";
    ASSERT_EQ(exit_code_, 0) << output_;
  }

  static inline const std::string kRunProtocols =
      "stereo '" + kProtocols + "servo_sweep_small.yaml' '" + kProtocols + "vergence_short.yaml'";
  static inline fs::path root_;
  static inline int exit_code_ = -1;
  static inline std::string output_;
};

TEST_F(CalibrateGolden, AFixedSeedRunGivesTheRecordedParameters) {
  const nlohmann::json now = Digest(root_ / "cal");
  if (std::getenv("OWLCAL_UPDATE_GOLDEN")) {
    fs::create_directories(fs::path(kGolden).parent_path());
    std::ofstream(kGolden) << now.dump(1) << "\n";
    GTEST_SKIP() << "wrote " << kGolden;
  }
  std::ifstream gf(kGolden);
  ASSERT_TRUE(gf) << kGolden << " is missing (OWLCAL_UPDATE_GOLDEN=1 writes it)";
  const nlohmann::json golden = nlohmann::json::parse(gf);

  const auto& gp = golden.at("parameters");
  const auto& np = now.at("parameters");
  ASSERT_GT(gp.size(), 40u);
  EXPECT_EQ(gp.size(), np.size());
  for (const auto& [name, g] : gp.items()) {
    ASSERT_TRUE(np.contains(name)) << name << " is no longer in results.json";
    const nlohmann::json& n = np.at(name);
    const double gv = g.at("value").get<double>(), nv = n.at("value").get<double>();
    const bool has_sigma = g.at("sigma").is_number() && g.at("sigma").get<double>() > 0;
    const double tol = has_sigma ? 1e-4 * g.at("sigma").get<double>() : 1e-9 * std::max(1.0, std::abs(gv));
    EXPECT_NEAR(nv, gv, tol) << name;
    EXPECT_EQ(n.at("sigma").is_number(), g.at("sigma").is_number()) << name;
    if (has_sigma && n.at("sigma").is_number()) {
      EXPECT_NEAR(n.at("sigma").get<double>(), g.at("sigma").get<double>(), 1e-4 * g.at("sigma").get<double>())
          << name << " sigma";
    }
  }
  ASSERT_EQ(now.at("ranging").size(), golden.at("ranging").size());
  for (size_t i = 0; i < golden.at("ranging").size(); ++i) {
    const auto &g = golden.at("ranging")[i], &n = now.at("ranging")[i];
    EXPECT_EQ(n.at("status"), g.at("status")) << "fixation " << i;
    if (g.at("range_m").is_number() && n.at("range_m").is_number()) {
      EXPECT_NEAR(n.at("range_m").get<double>(), g.at("range_m").get<double>(), 1e-7) << "fixation " << i;
    }
  }
  EXPECT_EQ(now.at("warnings"), golden.at("warnings"));
}

TEST_F(CalibrateGolden, TheDryRunPlansThePlacementsAndOpenLoopTimeTheDatasetsCount) {
  const auto plan = RunOwlcal("calibrate --dry-run --seed 3 --protocols " + kRunProtocols);
  ASSERT_EQ(plan.exit_code, 0) << plan.output;
  std::ifstream rf(root_ / "cal" / "results.json");
  const nlohmann::json pw = nlohmann::json::parse(rf).at("diagnostics").at("person_work");
  const nlohmann::json& counted = pw.at("counted");
  ASSERT_EQ(counted.size(), 3u) << pw.dump(1);
  // Per protocol, the dry-run's line: "  NAME  N placements (M place-target steps)  T s robot time".
  for (const nlohmann::json& c : counted) {
    const std::string name = c.at("protocol").get<std::string>();
    const size_t at = plan.output.find("  " + name + " ");
    ASSERT_NE(at, std::string::npos) << name << " is not in the dry-run:\n" << plan.output;
    std::istringstream line(plan.output.substr(at, plan.output.find('\n', at) - at));
    std::string word, steps_word;
    int placements = -1, steps = -1;
    double seconds = -1;
    line >> word >> placements >> word >> steps_word;
    if (steps_word == "(")
      line >> steps;
    else
      steps = std::stoi(steps_word.substr(1));
    line >> word >> word >> seconds;
    EXPECT_EQ(placements, c.at("placements").get<int>()) << name;
    EXPECT_EQ(steps, c.at("placement_steps").get<int>()) << name;
    // The open-loop steps take what was planned, to a frame period per step (the stream's phase);
    // the closed-loop ones (vergence's fixations) the time their images decide, on top.
    const double open_loop = c.at("robot_time_s").get<double>() - c.at("closed_loop_s").get<double>();
    EXPECT_NEAR(open_loop, seconds, 0.05 + 0.002 * open_loop) << name;
    if (c.at("closed_loop_steps").get<int>() > 0) {
      EXPECT_GT(c.at("closed_loop_s").get<double>(), 0.5) << name;
      EXPECT_NE(plan.output.find("closed-loop steps (their time is decided at run time)", at), std::string::npos);
    }
  }
  // The planned rows in results.json, from the datasets' recorded protocols, are the dry-run's.
  EXPECT_EQ(pw.at("planned_total").at("placements"), pw.at("counted_total").at("placements"));
  EXPECT_GE(pw.at("counted_total").at("placements").get<int>(), 3);
}

}  // namespace
}  // namespace owlcal
