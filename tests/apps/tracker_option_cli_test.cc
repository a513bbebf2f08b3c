// The experiment commands' --tracker option (apps/experiment_recording.h): `lk` or `disc` for
// every step that locates the target, whatever the protocol's `locator:` says; refused with a
// recorded --dataset (it was located as it was) and for any other name.
#include <unistd.h>

#include <filesystem>

#include <gtest/gtest.h>

#include "owlcal_version.h"
#include "tests/apps/run_owlcal.h"

namespace owlcal {
namespace {

namespace fs = std::filesystem;
using test_cli::RunOwlcal;

TEST(TrackerOptionCli, LkLocatesEveryStepAndIsRefusedWithADatasetOrAnUnknownName) {
  if (test_cli::OwlcalBinary().empty()) GTEST_SKIP() << "the owlcal binary is not built";
  const fs::path out = fs::temp_directory_path() / ("owlcal_tracker_option_" + std::to_string(::getpid()));
  fs::remove_all(out);
  const std::string protocol = std::string(OWLCAL_SOURCE_DIR) + "/tests/data/protocols/catch_up_short.yaml";
  const auto r =
      RunOwlcal("catch-up --tracker lk --no-figures --protocol '" + protocol + "' --out '" + out.string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("--tracker lk: 1 step(s) locate the target with it"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("10.0 deg/s: ok"), std::string::npos) << r.output;

  const auto again = RunOwlcal("catch-up --tracker disc --dataset '" + (out / "datasets" / "catch_up").string() +
                               "' --out '" + (out / "again").string() + "'");
  EXPECT_NE(again.exit_code, 0);
  EXPECT_NE(again.output.find("--tracker is for a new recording"), std::string::npos) << again.output;

  const auto unknown = RunOwlcal("vor --tracker template --out '" + (out / "x").string() + "'");
  EXPECT_NE(unknown.exit_code, 0);
  EXPECT_NE(unknown.output.find("--tracker"), std::string::npos) << unknown.output;
  fs::remove_all(out);
}

}  // namespace
}  // namespace owlcal
