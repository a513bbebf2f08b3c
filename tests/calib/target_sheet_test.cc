// Printable targets at true scale: the PDF is rasterised by poppler's pdftoppm and the SVG by
// librsvg's rsvg-convert (both installed by scripts/install-deps.sh), at a known resolution, and
// owlcal's detector must find the target with its squares / tags at their nominal size in mm
// and at the page position the layout promises; the scale bar must measure its length.
#include "calib/target_sheet.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "calib/detector.h"
#include "calib/target_file.h"
#include "owlcal_version.h"

namespace owlcal::calib {
namespace target_sheet_test {

namespace fs = std::filesystem;

fs::path TestDir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("owlcal_target_sheet_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

bool HaveTool(const std::string& tool) { return std::system(("command -v " + tool + " >/dev/null 2>&1").c_str()) == 0; }

// Writes `text` to dir/name.ext, rasterises it at `dpi` with the Debian tool for its format and
// returns the grey image (empty on failure, with a test failure naming the command).
cv::Mat Rasterise(const fs::path& dir, const std::string& text, bool pdf, int dpi) {
  const fs::path in = dir / (pdf ? "sheet.pdf" : "sheet.svg");
  std::ofstream(in, std::ios::binary) << text;
  const fs::path png = dir / "sheet.png";
  const std::string tool = pdf ? "pdftoppm" : "rsvg-convert";
  if (!HaveTool(tool)) {
    ADD_FAILURE() << tool << " is not installed: run scripts/install-deps.sh (poppler-utils, librsvg2-bin)";
    return {};
  }
  const std::string d = std::to_string(dpi);
  const std::string cmd =
      pdf ? "pdftoppm -r " + d + " -gray -png -singlefile '" + in.string() + "' '" + (dir / "sheet").string() + "'"
          : "rsvg-convert -d " + d + " -p " + d + " -b white -o '" + png.string() + "' '" + in.string() + "'";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  cv::Mat img = cv::imread(png.string(), cv::IMREAD_GRAYSCALE);
  EXPECT_FALSE(img.empty()) << "no image from: " << cmd;
  return img;
}

// Each detected corner against its position on the page (OpenCV pixel convention: the centre of
// pixel 0 is at 0.5 px of page distance). Corner ids of a chessboard may come in the reversed
// order (OpenCV's orientation ambiguity), so each corner is compared with the nearest nominal one.
double WorstCornerErrorPx(const TargetDetection& d, const TargetDefinition& t, const TargetSheet& s, double px_per_mm) {
  const auto nominal = t.Corners();
  double worst = 0;
  for (const Eigen::Vector2d& px : d.pixels) {
    double best = 1e9;
    for (const auto& [id, p] : nominal) {
      const Eigen::Vector2d expect = (s.target_origin_mm + 1000 * p.head<2>()) * px_per_mm - Eigen::Vector2d(0.5, 0.5);
      best = std::min(best, (expect - px).norm());
    }
    worst = std::max(worst, best);
  }
  return worst;
}

// Mean distance [px] between corners `step` ids apart on the same row of a chessboard.
double MeanSquarePx(const TargetDetection& d, int cols) {
  std::map<int, Eigen::Vector2d> by_id;
  for (size_t i = 0; i < d.corner_ids.size(); ++i) by_id[d.corner_ids[i]] = d.pixels[i];
  double sum = 0;
  int n = 0;
  for (const auto& [id, p] : by_id) {
    if (id % cols != cols - 1 && by_id.count(id + 1)) sum += (by_id[id + 1] - p).norm(), ++n;
    if (by_id.count(id + cols)) sum += (by_id[id + cols] - p).norm(), ++n;
  }
  return n ? sum / n : 0;
}

// Longest run of dark pixels in row y [px].
int LongestDarkRun(const cv::Mat& grey, int y) {
  int best = 0, run = 0;
  for (int x = 0; x < grey.cols; ++x) {
    run = grey.at<uint8_t>(y, x) < 128 ? run + 1 : 0;
    best = std::max(best, run);
  }
  return best;
}

TargetDefinition KitBoard() {
  return LoadTargetFile(std::string(OWLCAL_DATA_DIR) + "/targets/owl-kit-chessboard.yaml");
}
TargetDefinition Grid() { return LoadTargetFile(std::string(OWLCAL_DATA_DIR) + "/targets/aprilgrid-6x6.yaml"); }

TEST(TargetSheet, KitBoardNeedsA3AndRefusesA4WithTheSizes) {
  TargetSheetOptions o;
  const TargetSheet s = LayoutTargetSheet(KitBoard(), o);
  EXPECT_EQ(s.paper_name, "A3 landscape");
  EXPECT_DOUBLE_EQ(s.width_mm, 420);
  EXPECT_EQ(s.scale_bar_length_mm, 100);
  // 35 black squares of the 10 x 7 board, the bar and 11 ticks.
  EXPECT_EQ(s.black.size(), 35u + 1 + 11);
  o.paper = "A4";
  try {
    LayoutTargetSheet(KitBoard(), o);
    FAIL() << "a 260 x 182 mm board fitted on A4 with its text";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("does not fit"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("260.0 x 182.0 mm"), std::string::npos) << e.what();
  }
}

TEST(TargetSheet, RejectsWhatItCannotPrint) {
  TargetSheetOptions o;
  o.paper = "B5";
  std::string why;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("paper"), std::string::npos);
  o.paper = "300x300";
  EXPECT_TRUE(o.Check(&why)) << why;
  TargetDefinition fix;
  fix.kind = TargetKind::kFixation;
  EXPECT_THROW(LayoutTargetSheet(fix, o), std::invalid_argument);
  TargetDefinition g = Grid();
  g.first_id = 580;  // 36 tags from 580 run past tag36h11's 587 codes
  EXPECT_THROW(LayoutTargetSheet(g, o), std::invalid_argument);
  g = Grid();
  g.family = "tag25h9";
  EXPECT_THROW(LayoutTargetSheet(g, o), std::invalid_argument);
}

TEST(TargetSheet, ChessboardPdfMeasuresTrueScaleWhenRasterised) {
  const TargetDefinition t = KitBoard();
  const TargetSheet s = LayoutTargetSheet(t, {});
  const int dpi = 120;
  const double px_per_mm = dpi / 25.4;
  const cv::Mat img = Rasterise(TestDir("chess_pdf"), TargetSheetPdf(s), true, dpi);
  ASSERT_FALSE(img.empty());
  // The page itself: A3 landscape at 120 dpi.
  EXPECT_NEAR(img.cols, 420 * px_per_mm, 1.0);
  EXPECT_NEAR(img.rows, 297 * px_per_mm, 1.0);
  const TargetDetection d = DetectTarget(img, t, {});
  ASSERT_TRUE(d.found) << d.message;
  EXPECT_EQ(d.pixels.size(), 54u);
  const double square_mm = MeanSquarePx(d, t.cols) / px_per_mm;
  EXPECT_NEAR(square_mm, 26.0, 0.02);
  EXPECT_LT(WorstCornerErrorPx(d, t, s, px_per_mm), 0.35);
  // The scale bar: its rasterised length is its nominal length (+-1 px of edge rounding).
  const int bar_row = int((s.scale_bar_mm.y_mm + s.scale_bar_mm.h_mm / 2) * px_per_mm);
  EXPECT_NEAR(LongestDarkRun(img, bar_row) / px_per_mm, 100.0, 1.0 / px_per_mm + 1e-9);
}

TEST(TargetSheet, AprilGridSvgAndPdfMeasureTrueScaleWhenRasterised) {
  const TargetDefinition t = Grid();
  const TargetSheet s = LayoutTargetSheet(t, {});
  EXPECT_EQ(s.paper_name, "A4 portrait");
  for (const bool pdf : {false, true}) {
    SCOPED_TRACE(pdf ? "pdf" : "svg");
    const int dpi = 100;
    const double px_per_mm = dpi / 25.4;
    const cv::Mat img =
        Rasterise(TestDir(pdf ? "grid_pdf" : "grid_svg"), pdf ? TargetSheetPdf(s) : TargetSheetSvg(s), pdf, dpi);
    ASSERT_FALSE(img.empty());
    DetectorOptions o;
    o.apriltag_decimate = 1;
    const TargetDetection d = DetectTarget(img, t, o);
    ASSERT_TRUE(d.found) << d.message;
    EXPECT_EQ(d.pixels.size(), 4u * 36);
    // Tag size from each tag's top edge (corner 4 id + 0 to 4 id + 1).
    std::map<int, Eigen::Vector2d> by_id;
    for (size_t i = 0; i < d.corner_ids.size(); ++i) by_id[d.corner_ids[i]] = d.pixels[i];
    double sum = 0;
    int n = 0;
    for (int tag = 0; tag < 36; ++tag)
      if (by_id.count(4 * tag) && by_id.count(4 * tag + 1)) sum += (by_id[4 * tag + 1] - by_id[4 * tag]).norm(), ++n;
    ASSERT_EQ(n, 36);
    EXPECT_NEAR(sum / n / px_per_mm, 24.0, 0.1);
    // AprilTag ids fix the orientation: every corner at its own page position.
    const auto nominal = t.Corners();
    double worst = 0;
    for (size_t i = 0; i < d.corner_ids.size(); ++i) {
      const Eigen::Vector2d expect =
          (s.target_origin_mm + 1000 * nominal.at(d.corner_ids[i]).head<2>()) * px_per_mm - Eigen::Vector2d(0.5, 0.5);
      worst = std::max(worst, (expect - d.pixels[i]).norm());
    }
    EXPECT_LT(worst, 0.6);
    const int bar_row = int((s.scale_bar_mm.y_mm + s.scale_bar_mm.h_mm / 2) * px_per_mm);
    EXPECT_NEAR(LongestDarkRun(img, bar_row) / px_per_mm, 100.0, 1.0 / px_per_mm + 1e-9);
  }
}

}  // namespace target_sheet_test
}  // namespace owlcal::calib
