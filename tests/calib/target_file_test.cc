#include "calib/target_file.h"

#include <filesystem>

#include <gtest/gtest.h>

#include "owlcal_version.h"

namespace owlcal::calib {
namespace {

TEST(TargetFile, ShippedTargetsLoad) {
  const std::string dir = std::string(OWLCAL_SOURCE_DIR) + "/data/targets/";
  const TargetFile kit = LoadTargetFileWithUnit(dir + "owl-kit-chessboard.yaml");
  EXPECT_EQ(kit.target.kind, TargetKind::kChessboard);
  EXPECT_EQ(kit.target.cols, 9);
  EXPECT_EQ(kit.target.rows, 6);
  EXPECT_DOUBLE_EQ(kit.target.square_m, 0.026);
  EXPECT_EQ(kit.unit, "m");
  const TargetFile cv = LoadTargetFileWithUnit(dir + "opencv-sample-chessboard.yaml");
  EXPECT_DOUBLE_EQ(cv.target.square_m, 1.0);
  EXPECT_EQ(cv.unit, "square");
  const TargetDefinition grid = LoadTargetFile(dir + "aprilgrid-6x6.yaml");
  EXPECT_EQ(grid.kind, TargetKind::kAprilGrid);
  EXPECT_EQ(grid.NumCorners(), 144);
  EXPECT_DOUBLE_EQ(grid.tag_spacing, 0.3);
}

TEST(TargetFile, SaveLoadRoundTrip) {
  TargetDefinition t;
  t.kind = TargetKind::kAprilGrid;
  t.id = "g";
  t.tag_cols = 4;
  t.tag_rows = 3;
  t.tag_size_m = 0.0321;
  t.first_id = 12;
  const std::string p = (std::filesystem::temp_directory_path() / "owlcal_target_rt.yaml").string();
  SaveTargetFile(t, p);
  const TargetDefinition b = LoadTargetFile(p);
  EXPECT_EQ(b.id, "g");
  EXPECT_EQ(b.tag_cols, 4);
  EXPECT_EQ(b.tag_rows, 3);
  EXPECT_DOUBLE_EQ(b.tag_size_m, 0.0321);
  EXPECT_EQ(b.first_id, 12);
  EXPECT_EQ(b.Corners(), t.Corners());
  std::filesystem::remove(p);
}

TEST(TargetFile, ErrorsNameKeyAndValue) {
  auto msg = [](const std::string& yaml) {
    try {
      ParseTargetYaml(yaml, "t.yaml");
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(msg("target_type: chessboard\ncols: 9\nrows: 6\n").find("square_size_m"), std::string::npos);
  EXPECT_NE(msg("target_type: chessboard\ncols: 1\nrows: 6\nsquare_size_m: 0.02\n").find("cols"), std::string::npos);
  EXPECT_NE(msg("target_type: hexboard\n").find("hexboard"), std::string::npos);
  EXPECT_NE(msg("target_type: chessboard\ncols: 9\nrows: 6\nsquare_size_m: 0.02\nsquares: 3\n").find("squares"),
            std::string::npos);
  EXPECT_NE(msg("target_type: aprilgrid\ntagCols: 6\ntagRows: 6\ntagSize: x\ntagSpacing: 0.3\n").find("tagSize"),
            std::string::npos);
  EXPECT_NE(msg("target_type: chessboard\ncols: 9\nrows: 6\nsquare_size_m: 0.02\n").find("no error"),
            std::string::npos);
  EXPECT_THROW(LoadTargetFile("/nonexistent/t.yaml"), std::runtime_error);
}

TEST(TargetFile, RefusesRepeatedKeysBothSpellingsAndNonFiniteSizes) {
  auto msg = [](const std::string& yaml) {
    try {
      ParseTargetYaml(yaml, "t.yaml");
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(msg("target_type: chessboard\ncols: 9\nrows: 6\nsquare_size_m: 0.02\ncols: 7\n"),
            "t.yaml:5: key 'cols' given twice (first on line 2)");
  EXPECT_EQ(msg("target_type: chessboard\ncols: 9\ntargetCols: 7\nrows: 6\nsquare_size_m: 0.02\n"),
            "t.yaml:3: targetCols says the same as cols; give one of them");
  EXPECT_EQ(msg("target_type: chessboard\ncols: 9\nrows: 6\nsquare_size_m: .inf\n"),
            "t.yaml:4: square_size_m = '.inf' is not a finite decimal number");
  EXPECT_EQ(msg("target_type: chessboard\ncols: 9\nrows: 6\nsquare_size_m: -0.02\n"),
            "t.yaml:4: square_size_m = -0.02 is outside [1e-09, 1000]");
  EXPECT_EQ(msg("target_type: aprilgrid\ntagCols: 1000000000\ntagRows: 6\ntagSize: 0.02\ntagSpacing: 0.3\n"),
            "t.yaml:2: tagCols = 1000000000 is outside [1, 100]");
  EXPECT_EQ(msg("[target_type, chessboard]: 1\n"), "t.yaml:1: a key of the file is a list, not a name");
  EXPECT_EQ(msg(""), "t.yaml: the file is empty");
}

}  // namespace
}  // namespace owlcal::calib
