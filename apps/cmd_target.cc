// owlcal target TARGET.yaml --out SHEET.pdf|svg: a printable target at true scale, with the
// target YAML that describes exactly what was printed written next to it (SHEET.yaml).
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

#include "apps/command_registry.h"
#include "calib/target_file.h"
#include "calib/target_sheet.h"
#include "reports/table.h"

namespace owlcal::apps {
namespace {

namespace fs = std::filesystem;

struct TargetOptions {
  std::string target_path, out, paper = "auto", id;
  double square_mm = 0, tag_size_mm = 0, tag_spacing = -1, margin_mm = 8;
  int cols = 0, rows = 0;
};

int RunTarget(const TargetOptions& a) {
  calib::TargetFile tf = calib::LoadTargetFileWithUnit(a.target_path);
  calib::TargetDefinition& t = tf.target;
  const bool chess = t.kind == calib::TargetKind::kChessboard;
  if (!a.id.empty()) t.id = a.id;
  if (a.cols > 0) (chess ? t.cols : t.tag_cols) = a.cols;
  if (a.rows > 0) (chess ? t.rows : t.tag_rows) = a.rows;
  if (a.square_mm > 0) {
    if (!chess)
      throw UsageError("--square-mm is for chessboards; " + a.target_path + " is an AprilGrid (use --tag-size-mm)");
    t.square_m = a.square_mm / 1000;
  }
  if (a.tag_size_mm > 0) {
    if (chess)
      throw UsageError("--tag-size-mm is for AprilGrids; " + a.target_path + " is a chessboard (use --square-mm)");
    t.tag_size_m = a.tag_size_mm / 1000;
  }
  if (a.tag_spacing >= 0) t.tag_spacing = a.tag_spacing;
  const bool size_given = a.square_mm > 0 || a.tag_size_mm > 0;
  if (tf.unit != "m" && !size_given)
    throw UsageError(a.target_path + ": sizes are in '" + tf.unit +
                     "', not metres; give --square-mm or --tag-size-mm " + "to print it at a true scale");

  const fs::path out(a.out);
  std::string ext = out.extension().string();
  for (char& c : ext) c = char(::tolower(c));
  if (ext != ".pdf" && ext != ".svg") throw UsageError("--out must end in .pdf or .svg, got '" + a.out + "'");
  calib::TargetSheetOptions o;
  o.paper = a.paper;
  o.printer_margin_mm = a.margin_mm;
  o.note = "Target file: " + out.stem().string() + ".yaml (owlcal --target). Made by owlcal target.";
  std::string why;
  if (!o.Check(&why)) throw UsageError(why);
  calib::TargetSheet sheet;
  try {
    sheet = calib::LayoutTargetSheet(t, o);
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  if (out.has_parent_path()) fs::create_directories(out.parent_path());
  reports::WriteTextFile(out.string(), ext == ".pdf" ? calib::TargetSheetPdf(sheet) : calib::TargetSheetSvg(sheet));

  // The YAML owlcal reads, in metres, with a header saying what it describes.
  fs::path yaml = out;
  yaml.replace_extension(".yaml");
  calib::SaveTargetFile(t, yaml.string(), "m");
  std::ifstream in(yaml);
  std::stringstream body;
  body << in.rdbuf();
  in.close();
  reports::WriteTextFile(yaml.string(),
                         "# Printed by owlcal target as " + out.filename().string() + " (" + sheet.paper_name +
                             ", 100 % scale): " + calib::DescribeTargetDimensions(t) +
                             ".\n# Measure the printed sheet (scale bar " +
                             std::to_string(int(sheet.scale_bar_length_mm)) +
                             " mm) and correct the sizes here if the printer scaled it.\n" + body.str());
  // Round trip: the file just written must describe the same target.
  const calib::TargetDefinition back = calib::LoadTargetFile(yaml.string());
  if (back.NumCorners() != t.NumCorners() || std::abs(back.square_m - t.square_m) > 1e-9 ||
      std::abs(back.tag_size_m - t.tag_size_m) > 1e-9)
    throw std::runtime_error(yaml.string() + ": written target does not read back identically");

  std::cout << "wrote " << out.string() << " (" << sheet.paper_name << ", " << sheet.width_mm << " x "
            << sheet.height_mm << " mm): " << calib::DescribeTargetDimensions(t) << "\nwrote " << yaml.string()
            << " (use it as --target)\nPrint at 100 % (actual size) and check the " << sheet.scale_bar_length_mm
            << " mm scale bar with a ruler.\n";
  return kExitOk;
}

const bool kTargetRegistered = RegisterCommand(
    "target",
    "Write a printable calibration target at true scale (PDF or SVG by --out's extension): a chessboard or\n"
    "AprilGrid from a target file (data/targets/*.yaml), with its dimensions and a scale-check bar, and the\n"
    "target YAML that owlcal reads next to it (same name, .yaml).",
    [](CLI::App* cmd) {
      auto o = std::make_shared<TargetOptions>();
      cmd->add_option("target", o->target_path, "target file (data/targets/*.yaml)")
          ->required()
          ->check(CLI::ExistingFile);
      cmd->add_option("--out", o->out, "sheet to write: NAME.pdf or NAME.svg (NAME.yaml is written beside it)")
          ->required();
      cmd->add_option("--paper", o->paper, "auto, A4, A3, A2, A1, A0, letter, legal or WxH in mm")
          ->capture_default_str();
      cmd->add_option("--margin-mm", o->margin_mm, "printer margin kept free at each edge [mm]")->capture_default_str();
      cmd->add_option("--square-mm", o->square_mm, "chessboard square size [mm] (overrides the file)");
      cmd->add_option("--tag-size-mm", o->tag_size_mm, "AprilGrid tag size, black border [mm] (overrides the file)");
      cmd->add_option("--tag-spacing", o->tag_spacing, "AprilGrid gap / tag size (overrides the file)");
      cmd->add_option("--cols", o->cols, "inner corners (chessboard) or tags (AprilGrid) across (overrides)");
      cmd->add_option("--rows", o->rows, "inner corners (chessboard) or tags (AprilGrid) down (overrides)");
      cmd->add_option("--id", o->id, "target id written to the YAML and observations (overrides)");
      return [o] { return RunTarget(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
