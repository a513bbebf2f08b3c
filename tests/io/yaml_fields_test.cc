#include "io/yaml_fields.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

namespace owlcal::io {
namespace {

std::string ErrorOf(const std::string& text) {
  try {
    LoadYamlText(text, "robot.yaml");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(LoadYamlText, StrayTopLevelCommaIsAnErrorNotAHang) {
  // fuzz/robot_truth_fuzz found it: yaml-cpp 0.7's LoadAll(",") never returns.
  EXPECT_EQ(ErrorOf(","), "robot.yaml:1:1: not valid YAML: unexpected ','");
  EXPECT_EQ(ErrorOf(",~ 578 px with stronger distortion"), "robot.yaml:1:1: not valid YAML: unexpected ','");
  EXPECT_NE(ErrorOf("name: a\n,\n").find("robot.yaml:2"), std::string::npos) << ErrorOf("name: a\n,\n");
}

TEST(LoadYamlText, ReadsOneDocumentAndRefusesASecond) {
  const YAML::Node n = LoadYamlText("name: a\nipd_m: 0.065\n", "robot.yaml");
  EXPECT_EQ(n["name"].as<std::string>(), "a");
  EXPECT_EQ(ErrorOf("name: a\n---\nname: b\n"), "robot.yaml:2: a second YAML document ('---') is not allowed");
  EXPECT_EQ(ErrorOf(""), "robot.yaml: the file is empty");
  EXPECT_EQ(ErrorOf("# only a comment\n"), "robot.yaml: the file is empty");
  EXPECT_NE(ErrorOf("a: [1, 2\n").find("robot.yaml:"), std::string::npos);
}

}  // namespace
}  // namespace owlcal::io
