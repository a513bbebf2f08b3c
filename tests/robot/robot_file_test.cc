#include "robot/robot_file.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "owlcal_version.h"

namespace owlcal::robot {
namespace {

void ExpectSameConfig(const models::RobotConfig& a, const models::RobotConfig& b) {
  EXPECT_EQ(a.name, b.name);
  EXPECT_DOUBLE_EQ(a.ipd_m, b.ipd_m);
  EXPECT_EQ(a.image_width, b.image_width);
  EXPECT_EQ(a.image_height, b.image_height);
  EXPECT_EQ(a.swap_eyes, b.swap_eyes);
  EXPECT_EQ(a.mirror_stream, b.mirror_stream);
  for (int i = 0; i < models::kNumServos; ++i) {
    SCOPED_TRACE(models::kServoNames[i]);
    EXPECT_EQ(a.servos[i].name, b.servos[i].name);
    EXPECT_EQ(a.servos[i].min_us, b.servos[i].min_us);
    EXPECT_EQ(a.servos[i].max_us, b.servos[i].max_us);
    EXPECT_EQ(a.servos[i].centre_us, b.servos[i].centre_us);
    EXPECT_EQ(a.servos[i].direction, b.servos[i].direction);
    EXPECT_DOUBLE_EQ(a.servos[i].nominal_deg_per_us, b.servos[i].nominal_deg_per_us);
  }
}

const char* kGuide = R"(name: guide-owl
ipd_mm: 65.0
image: {width: 640, height: 480, swap_eyes: false, mirror: true}
servos:
  Rx:   {min_us: 1200, max_us: 1890, centre_us: 1545, direction: 1,  deg_per_us: 0.113}
  Ry:   {min_us: 1120, max_us: 2000, centre_us: 1530, direction: 1,  deg_per_us: 0.113}
  Lx:   {min_us: 1180, max_us: 1850, centre_us: 1545, direction: 1,  deg_per_us: 0.113}
  Ly:   {min_us: 1180, max_us: 2000, centre_us: 1580, direction: -1, deg_per_us: 0.113}
  Neck: {min_us: 1100, max_us: 1950, centre_us: 1530, direction: -1, deg_per_us: 0.113}
)";

// Replaces the first occurrence of `from` in the guide text.
std::string Edited(const std::string& from, const std::string& to) {
  std::string s = kGuide;
  const size_t pos = s.find(from);
  EXPECT_NE(pos, std::string::npos) << from;
  return s.replace(pos, from.size(), to);
}

std::string ErrorOf(const std::string& text) {
  try {
    RobotConfigFromYaml(YAML::Load(text), "robots/x.yaml");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(RobotFile, ShippedGuideRobotEqualsTheDefault) {
  const std::string path = std::string(OWLCAL_SOURCE_DIR) + "/data/robots/guide-owl.yaml";
  ExpectSameConfig(LoadRobotFile(path), models::DefaultRobotConfig());
}

TEST(RobotFile, ParsesTheDocumentedFormat) {
  ExpectSameConfig(RobotConfigFromYaml(YAML::Load(kGuide), "x"), models::DefaultRobotConfig());
}

TEST(RobotFile, SaveThenLoadRoundTrips) {
  models::RobotConfig c = models::DefaultRobotConfig();
  c.name = "my owl";
  c.ipd_m = 0.0649;
  c.swap_eyes = true;
  c.mirror_stream = false;  // not the default (a real Owl streams mirrored)
  c.servos[models::kRx].centre_us = 1502;
  c.servos[models::kLy].nominal_deg_per_us = 0.1017;
  const std::string path = (std::filesystem::temp_directory_path() / "owlcal_robot_file_test.yaml").string();
  SaveRobotFile(c, path);
  ExpectSameConfig(LoadRobotFile(path), c);
  std::filesystem::remove(path);
}

TEST(RobotFile, OptionalFieldsTakeDefaults) {
  const models::RobotConfig c = RobotConfigFromYaml(YAML::Load(R"(servos:
  Rx:   {min_us: 1200, max_us: 1890, centre_us: 1545, direction: 1}
  Ry:   {min_us: 1120, max_us: 2000, centre_us: 1530, direction: 1}
  Lx:   {min_us: 1180, max_us: 1850, centre_us: 1545, direction: 1}
  Ly:   {min_us: 1180, max_us: 2000, centre_us: 1580, direction: -1}
  Neck: {min_us: 1100, max_us: 1950, centre_us: 1530, direction: -1}
)"),
                                                    "robots/bench-owl.yaml");
  EXPECT_EQ(c.name, "bench-owl");
  EXPECT_DOUBLE_EQ(c.ipd_m, 0.065);
  EXPECT_DOUBLE_EQ(c.servos[models::kNeck].nominal_deg_per_us, 0.113);
}

TEST(RobotFile, ErrorsNameTheFileFieldAndValue) {
  EXPECT_EQ(ErrorOf(Edited("min_us: 1200", "min_us: 2100")),
            "robots/x.yaml: servos.Rx.min_us = 2100 is above max_us 1890");
  EXPECT_EQ(ErrorOf(Edited("centre_us: 1530, direction: 1", "centre_us: 2030, direction: 1")),
            "robots/x.yaml: servos.Ry.centre_us = 2030 is not below max_us 2000");
  EXPECT_EQ(ErrorOf(Edited("centre_us: 1545, direction: 1,  deg_per_us: 0.113}\n  Ry",
                           "centre_us: 1100, direction: 1,  deg_per_us: 0.113}\n  Ry")),
            "robots/x.yaml: servos.Rx.centre_us = 1100 is not above min_us 1200");
  EXPECT_EQ(ErrorOf(Edited("max_us: 1850", "max_us: 18500")),
            "robots/x.yaml: servos.Lx.max_us = 18500 is not a four-digit pulse width (1000..9999 us)");
  EXPECT_EQ(ErrorOf(Edited("direction: -1", "direction: 2")), "robots/x.yaml: servos.Ly.direction = 2 is not 1 or -1");
  EXPECT_EQ(ErrorOf(Edited("direction: -1, deg_per_us: 0.113}\n  Neck", "direction: -1, deg_per_us: 0}\n  Neck")),
            "robots/x.yaml: servos.Ly.deg_per_us = 0 is not positive");
  EXPECT_EQ(ErrorOf(Edited("min_us: 1100", "min_us: abc")),
            "robots/x.yaml:9: servos.Neck.min_us = 'abc' is not an integer");
  EXPECT_EQ(ErrorOf(Edited("min_us: 1100", "min_us: 1100.5")),
            "robots/x.yaml:9: servos.Neck.min_us = '1100.5' is not an integer");
  EXPECT_EQ(ErrorOf(Edited("ipd_mm: 65.0", "ipd_mm: -3")), "robots/x.yaml: ipd_mm = -3 is not in (0, 1000] mm");
  EXPECT_EQ(ErrorOf(Edited("swap_eyes: false", "swap_eyes: maybe")),
            "robots/x.yaml:3: image.swap_eyes = 'maybe' is not true or false");
  EXPECT_NE(ErrorOf(Edited("  Neck: {", "  Nek: {")).find("unknown field 'servos.Nek'"), std::string::npos);
  EXPECT_EQ(ErrorOf(Edited("centre_us: 1530, direction: -1", "centre_us: 1530")),
            "robots/x.yaml:9: missing field servos.Neck.direction");
  EXPECT_EQ(ErrorOf(""), "robots/x.yaml: the file is empty");
  EXPECT_EQ(ErrorOf(kGuide), "");
}

TEST(RobotFile, MissingOrBrokenFilesNameThePath) {
  try {
    LoadRobotFile("/nonexistent/owl.yaml");
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), "/nonexistent/owl.yaml: cannot open robot file");
  }
  const std::string path = (std::filesystem::temp_directory_path() / "owlcal_broken_robot.yaml").string();
  std::ofstream(path) << "servos: {Rx: [1, 2\n";
  try {
    LoadRobotFile(path);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()).rfind(path + ":2:1: not valid YAML", 0), 0u) << e.what();
  }
  std::filesystem::remove(path);
}

// Issue table "Smaller": robot files accepted a 10^6 x 10^6 image and duplicate keys, and a YAML
// list as a key gave "bad conversion" with no file named.
TEST(RobotFile, RefusesAbsurdImagesRepeatedKeysAndListsWhereNamesBelong) {
  EXPECT_EQ(ErrorOf(Edited("width: 640, height: 480", "width: 1000000, height: 1000000")),
            "robots/x.yaml: image.width = 1000000 is not in 16..8192 px");
  EXPECT_EQ(ErrorOf(Edited("height: 480", "height: 0")), "robots/x.yaml: image.height = 0 is not in 16..8192 px");
  EXPECT_EQ(ErrorOf(Edited("ipd_mm: 65.0\n", "ipd_mm: 65.0\nipd_mm: 58\n")),
            "robots/x.yaml:3: key 'ipd_mm' given twice (first on line 2)");
  EXPECT_EQ(ErrorOf(Edited("min_us: 1200, max_us: 1890", "min_us: 1200, min_us: 1100, max_us: 1890")),
            "robots/x.yaml:5: key 'servos.Rx.min_us' given twice (first on line 5)");
  EXPECT_EQ(ErrorOf(Edited("  Lx:   {", "  [Lx, Rx]:   {")),
            "robots/x.yaml:7: a key of 'servos' is a list, not a name");
  EXPECT_EQ(ErrorOf(Edited("centre_us: 1545, direction: 1,  deg_per_us: 0.113}\n  Ry",
                           "centre_us: [1545], direction: 1,  deg_per_us: 0.113}\n  Ry")),
            "robots/x.yaml:5: servos.Rx.centre_us must be a single value, not a list");
  EXPECT_EQ(ErrorOf(Edited("ipd_mm: 65.0", "ipd_mm: .nan")),
            "robots/x.yaml:2: ipd_mm = '.nan' is not a finite decimal number");
  EXPECT_EQ(ErrorOf(Edited("ipd_mm: 65.0", "ipd_mm: 1e400")),
            "robots/x.yaml:2: ipd_mm = '1e400' is not a finite decimal number");
  EXPECT_EQ(ErrorOf(Edited("min_us: 1100", "min_us: 0x44c")),
            "robots/x.yaml:9: servos.Neck.min_us = '0x44c' is not an integer");
  EXPECT_EQ(ErrorOf(Edited("image: {", "colour: red\nimage: {")),
            "robots/x.yaml:3: unknown field 'colour' (expected one of: name, ipd_mm, image, servos)");
  EXPECT_EQ(ErrorOf("- just\n- a list\n"), "robots/x.yaml:1: the file must be a map of key: value");
}

TEST(RobotFile, SaveRefusesAnInvalidConfig) {
  models::RobotConfig c = models::DefaultRobotConfig();
  c.servos[models::kRy].direction = 0;
  EXPECT_THROW(SaveRobotFile(c, "/tmp/owlcal_never_written.yaml"), std::runtime_error);
  EXPECT_FALSE(std::filesystem::exists("/tmp/owlcal_never_written.yaml"));
}

}  // namespace
}  // namespace owlcal::robot
