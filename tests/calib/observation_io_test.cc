#include "calib/observation_io.h"

#include <filesystem>
#include <fstream>
#include <tuple>

#include <gtest/gtest.h>

#include "calib/csv.h"

namespace owlcal::calib {
namespace {

std::string TempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("owlcal_obsio_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

std::vector<CornerObservation> Sample() {
  std::vector<CornerObservation> v;
  for (int i = 0; i < 3; ++i) {
    CornerObservation o;
    o.frame_index = 10 + i;
    o.eye = i % 2;
    o.target_id = "owl-kit";
    o.corner_id = 5 * i;
    o.pixel = Eigen::Vector2d(100.123456789012345 + i, 200.0 / 3.0);
    o.point_in_target = Eigen::Vector3d(0.026 * i, 0.052, 0);
    o.pwm_us = {1545, 1530, 1545 + i, 1580, 1530};
    o.approach = {1, -1, 0, 1, int8_t(i == 2 ? -1 : 0)};
    o.stamp_ns = 1234567890123LL + i;
    v.push_back(o);
  }
  return v;
}

TEST(ObservationCsv, RoundTripIsExact) {
  const std::string p = TempPath("rt.csv");
  const auto obs = Sample();
  WriteObservationsCsv(p, obs);
  const auto back = ReadObservationsCsv(p);
  ASSERT_EQ(back.size(), obs.size());
  for (size_t i = 0; i < obs.size(); ++i) {
    EXPECT_EQ(back[i].frame_index, obs[i].frame_index);
    EXPECT_EQ(back[i].eye, obs[i].eye);
    EXPECT_EQ(back[i].target_id, obs[i].target_id);
    EXPECT_EQ(back[i].corner_id, obs[i].corner_id);
    EXPECT_EQ(back[i].pixel, obs[i].pixel);  // bit-exact
    EXPECT_EQ(back[i].point_in_target, obs[i].point_in_target);
    EXPECT_EQ(back[i].pwm_us, obs[i].pwm_us);
    EXPECT_EQ(back[i].approach, obs[i].approach);
    EXPECT_EQ(back[i].stamp_ns, obs[i].stamp_ns);
  }
  std::filesystem::remove(p);
}

TEST(ObservationCsv, AppendWritesHeaderOnce) {
  const std::string p = TempPath("app.csv");
  std::filesystem::remove(p);
  AppendObservationsCsv(p, Sample());
  auto later = Sample();  // later frames: the same corners again would be duplicates
  for (auto& o : later) o.frame_index += 10;
  AppendObservationsCsv(p, later);
  EXPECT_EQ(ReadObservationsCsv(p).size(), 6u);
  std::filesystem::remove(p);
}

// Regression: every row duplicated was accepted and the sigmas shrank by about 1/sqrt(2). A corner
// repeated in one view is refused, naming both lines; the same corner in another frame or eye is not
// a duplicate.
TEST(ObservationCsv, ACornerRepeatedInAViewIsRefusedNamingBothLines) {
  const std::string p = TempPath("dup.csv");
  std::filesystem::remove(p);
  AppendObservationsCsv(p, Sample());
  AppendObservationsCsv(p, Sample());
  try {
    ReadObservationsCsv(p);
    FAIL() << "duplicated rows accepted";
  } catch (const std::runtime_error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(p + ":5: corner 0 of target 'owl-kit' in frame 10, left eye, is already on " + p + ":2"),
              std::string::npos)
        << m;
  }
  auto other_eye = Sample();
  for (auto& o : other_eye) o.eye = 1 - o.eye;
  WriteObservationsCsv(p, Sample());
  AppendObservationsCsv(p, other_eye);
  EXPECT_EQ(ReadObservationsCsv(p).size(), 6u);
  std::filesystem::remove(p);
}

TEST(ObservationCsv, TruncatedLastLineIsDropped) {
  const std::string p = TempPath("trunc.csv");
  WriteObservationsCsv(p, Sample());
  {
    std::ofstream f(p, std::ios::app);
    f << "13,left,owl-kit,4,101.5,";  // recording cut short, no newline
  }
  EXPECT_EQ(ReadObservationsCsv(p).size(), 3u);
  std::filesystem::remove(p);
}

TEST(ObservationCsv, BadLineNamesFileLineAndField) {
  const std::string p = TempPath("bad.csv");
  WriteObservationsCsv(p, Sample());
  {
    std::ofstream f(p, std::ios::app);
    f << "13,middle,owl-kit,4,1,2,0,0,0,1,2,3,4,5,0,0,0,0,0,7\n";
    f << "14,left,owl-kit,4,1,2,0,0,0,1,2,3,4,5,0,0,0,0,0,7\n";
  }
  try {
    ReadObservationsCsv(p);
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(p + ":5:"), std::string::npos) << m;
    EXPECT_NE(m.find("eye"), std::string::npos) << m;
    EXPECT_NE(m.find("middle"), std::string::npos) << m;
  }
  std::filesystem::remove(p);
  EXPECT_THROW(ReadObservationsCsv(p), std::runtime_error);  // missing file
}

// Issue table "Crashes": a nan, inf or 1e300 pixel reached Ceres and aborted `fit` with a CHECK.
// Each hostile cell is refused by the reader, naming the file, line and column.
TEST(ObservationCsv, RejectsNonFiniteHugeAndHexNumbers) {
  const std::string good = "13,left,owl-kit,4,101.5,202.5,0,0,0,1545,1530,1545,1580,1530,0,0,0,0,0,7";
  struct Case {
    int field;
    const char* value;
    const char* column;
  };
  for (const Case& c : {Case{4, "nan", "u_px"},
                        Case{4, "inf", "u_px"},
                        Case{5, "1e300", "v_px"},
                        Case{5, "-nan", "v_px"},
                        Case{6, "0x10", "x_m"},
                        Case{8, "", "z_m"},
                        Case{9, "1e3", "Rx_us"},
                        Case{13, "99999", "Neck_us"},
                        Case{14, "2", "approach_Rx"},
                        Case{0, "-1", "frame_index"},
                        Case{3, "4294967296", "corner_id"},
                        Case{19, "1.5", "stamp_ns"}}) {
    std::vector<std::string> cells = SplitCsvLine(good);
    cells[c.field] = c.value;
    std::string line;
    for (const std::string& cell : cells) line += (line.empty() ? "" : ",") + cell;
    const std::string p = TempPath("hostile.csv");
    WriteObservationsCsv(p, Sample());
    std::ofstream(p, std::ios::app) << line << "\n";
    try {
      ReadObservationsCsv(p);
      ADD_FAILURE() << c.column << " = '" << c.value << "' was accepted";
    } catch (const std::runtime_error& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find(p + ":5: column " + c.column), std::string::npos) << m;
    }
    std::filesystem::remove(p);
  }
}

TEST(ObservationCsv, HeaderMustNameEveryColumnOnce) {
  const std::string p = TempPath("header.csv");
  WriteObservationsCsv(p, Sample());
  std::string text;
  {
    std::ifstream in(p);
    text.assign(std::istreambuf_iterator<char>(in), {});
  }
  const std::string header = text.substr(0, text.find('\n'));
  for (const auto& [from, to, expect] : std::vector<std::tuple<std::string, std::string, std::string>>{
           {"v_px", "w_px", "missing column 'v_px'"},
           {"stamp_ns", "stamp_ns,extra", "unknown column 'extra'"},
           {"x_m", "u_px", "column 'u_px' appears twice"}}) {
    std::string h = header;
    h.replace(h.find(from), from.size(), to);
    std::ofstream(p, std::ios::trunc) << h << "\n";
    try {
      ReadObservationsCsv(p);
      ADD_FAILURE() << h;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(p + ":1: " + expect), std::string::npos) << e.what();
    }
  }
  std::filesystem::remove(p);
}

}  // namespace
}  // namespace owlcal::calib
