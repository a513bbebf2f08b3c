// Every Markdown table calibrate-images writes (calibration.md and the report's tables/*.md) is
// well formed: a header, a separator row of the same number of cells, and rows of that number
// too (the per-eye verdict table once had 12 header cells over an 11-cell separator). Run on
// OpenCV's stereo sample with the lens model and board bow chosen, so that every table is there.
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/apps/run_owlcal.h"
#include "tests/shared_data.h"

namespace owlcal {
namespace {

namespace fs = std::filesystem;
using test_cli::RunOwlcal;

// Cells of one pipe-table line: the text between unescaped '|', without the outer pipes.
std::vector<std::string> Cells(const std::string& line) {
  std::vector<std::string> cells;
  std::string cur;
  bool started = false;
  for (size_t i = 0; i < line.size(); ++i) {
    if (line[i] == '\\' && i + 1 < line.size()) {
      cur += line.substr(i, 2);
      ++i;
    } else if (line[i] == '|') {
      if (started) cells.push_back(cur);
      started = true;
      cur.clear();
    } else {
      cur += line[i];
    }
  }
  return cells;
}

struct TableCheck {
  int tables = 0;
  std::vector<std::string> problems;
};

// Checks every block of consecutive lines that start with '|'.
void CheckMarkdownTables(const fs::path& file, TableCheck* out) {
  std::ifstream in(file);
  ASSERT_TRUE(in) << file;
  std::vector<std::pair<int, std::string>> block;
  std::string line;
  int n = 0;
  const std::regex separator(R"(\s*:?-{3,}:?\s*)");
  auto flush = [&] {
    if (block.empty()) return;
    ++out->tables;
    const size_t header = Cells(block[0].second).size();
    const std::string where = file.filename().string() + ":" + std::to_string(block[0].first);
    if (block.size() < 2) out->problems.push_back(where + ": a header with no separator row");
    for (size_t i = 1; i < block.size(); ++i) {
      const std::vector<std::string> c = Cells(block[i].second);
      if (c.size() != header)
        out->problems.push_back(file.filename().string() + ":" + std::to_string(block[i].first) + ": " +
                                std::to_string(c.size()) + " cells under a header of " + std::to_string(header));
      if (i == 1)
        for (const auto& cell : c)
          if (!std::regex_match(cell, separator)) out->problems.push_back(where + ": separator cell '" + cell + "'");
    }
    block.clear();
  };
  while (std::getline(in, line)) {
    ++n;
    if (!line.empty() && line[0] == '|')
      block.push_back({n, line});
    else
      flush();
  }
  flush();
}

TEST(CalibrateImagesTablesCli, EveryMarkdownTableIsWellFormed) {
  if (test_cli::OwlcalBinary().empty()) GTEST_SKIP() << "the owlcal binary is not built";
  const fs::path dir = fs::temp_directory_path() / ("owlcal_calibrate_images_tables_cli_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const std::string data = test_data::SharedData();
  const auto r = RunOwlcal("calibrate-images '" + data + "/opencv-stereo-chessboard' --target '" + data +
                           "/targets/opencv-sample-chessboard.yaml' --out '" + dir.string() + "'");
  ASSERT_TRUE(fs::exists(dir / "calibration.md")) << r.output;
  TableCheck check;
  CheckMarkdownTables(dir / "calibration.md", &check);
  const int in_md = check.tables;
  ASSERT_TRUE(fs::is_directory(dir / "tables")) << r.output;
  for (const auto& e : fs::directory_iterator(dir / "tables"))
    if (e.path().extension() == ".md") CheckMarkdownTables(e.path(), &check);
  std::cout << check.tables << " Markdown tables (" << in_md << " in calibration.md)\n";
  // verdict, lens model, board, parameters and two per-eye view tables at least.
  EXPECT_GE(in_md, 6);
  EXPECT_GT(check.tables, in_md);
  for (const auto& p : check.problems) ADD_FAILURE() << p;
  std::error_code ec;
  fs::remove_all(dir, ec);
}

// Board bow "auto" shows what it gains and what it does to the lens: on kit2020-chessboard the
// bow's gain is within noise (fitting/lens_model_choice.h) and the flat board is kept, and
// calibration.md still gives the held-out gain with its standard error, which test failed, and a
// well-formed table of fx, k1, k2, k3 per eye, flat against bowed, in the flat fit's sigma.
TEST(CalibrateImagesTablesCli, TheBowsGainAndItsEffectOnTheLensAreShown) {
  if (test_cli::OwlcalBinary().empty()) GTEST_SKIP() << "the owlcal binary is not built";
  const fs::path dir = fs::temp_directory_path() / ("owlcal_calibrate_images_bow_cli_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const std::string data = test_data::SharedData();
  const auto r = RunOwlcal("calibrate-images '" + data + "/owl-real/kit2020-chessboard' --target '" + data +
                           "/targets/owl-kit-chessboard.yaml' --no-report --out '" + dir.string() + "'");
  ASSERT_TRUE(fs::exists(dir / "calibration.md")) << r.output;
  std::ifstream in(dir / "calibration.md");
  std::stringstream md;
  md << in.rdbuf();
  const std::string text = md.str();
  EXPECT_NE(text.find("## Board: flat"), std::string::npos) << text;
  EXPECT_NE(text.find("the bow's gain is within twice its standard error"), std::string::npos) << text;
  EXPECT_NE(text.find("Held-out gain of the bow: "), std::string::npos) << text;
  EXPECT_NE(text.find("| parameter | flat | bowed | bowed - flat | in flat sigma |"), std::string::npos) << text;
  for (const char* p : {"| left.fx |", "| left.k2 |", "| right.k3 |"}) EXPECT_NE(text.find(p), std::string::npos) << p;
  TableCheck check;
  CheckMarkdownTables(dir / "calibration.md", &check);
  for (const auto& p : check.problems) ADD_FAILURE() << p;
  std::error_code ec;
  fs::remove_all(dir, ec);
}

}  // namespace
}  // namespace owlcal
