// results.json read strictly: `report` wrote calibration.yaml full of NaN from fx = 0.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "fitting/result.h"

namespace owlcal::fitting {
namespace {

std::string Write(const std::string& name, const std::string& text) {
  const auto p = std::filesystem::temp_directory_path() / (name + "_" + std::to_string(::getpid()) + ".json");
  std::ofstream(p) << text;
  return p.string();
}

std::string ResultText() {
  CalibrationResult r;
  r.cameras[0] = models::CameraIntrinsics{};
  r.cameras[1] = models::CameraIntrinsics{};
  const std::string path = Write("owlcal_result_io_src", "");
  WriteResultJson(r, path);
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  std::filesystem::remove(path);
  return s.str();
}

std::string ErrorOf(const std::string& text) {
  const std::string path = Write("owlcal_result_io", text);
  try {
    ReadResultJson(path);
  } catch (const std::exception& e) {
    std::filesystem::remove(path);
    return e.what();
  }
  std::filesystem::remove(path);
  return "";
}

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

TEST(ResultJson, ReadsWhatItWrites) { EXPECT_EQ(ErrorOf(ResultText()), ""); }

TEST(ResultJson, RefusesAZeroOrMissingFocalLength) {
  const std::string text = ResultText();
  // The first camera's params list starts with fx = 585.0.
  std::string e = ErrorOf(Replace(text, "585.0", "0.0"));
  EXPECT_NE(e.find("cameras.left: camera params[0] (fx) = 0.000000 must be > 0"), std::string::npos) << e;
  e = ErrorOf(Replace(text, "585.0", "null"));  // a NaN is written as null
  EXPECT_NE(e.find("cameras.left: camera params[0] (fx) is null, not a number"), std::string::npos) << e;
  e = ErrorOf(Replace(text, "585.0", "-3"));
  EXPECT_NE(e.find("(fx) = -3.000000 must be > 0"), std::string::npos) << e;
  e = ErrorOf(Replace(text, "585.0", "1e999"));
  EXPECT_NE(e.find("not valid JSON"), std::string::npos) << e;
}

TEST(ResultJson, RefusesARepeatedKey) {
  const std::string text = ResultText();
  const std::string e = ErrorOf(Replace(text, "\"parameters\":", "\"warnings\": [],\n  \"parameters\":"));
  EXPECT_NE(e.find("key 'warnings' given twice"), std::string::npos) << e;
  const std::string f = ErrorOf(Replace(text, "\"width\":", "\"height\": 2, \"width\":"));
  EXPECT_NE(f.find("key 'cameras.left.height' given twice"), std::string::npos) << f;
}

}  // namespace
}  // namespace owlcal::fitting
