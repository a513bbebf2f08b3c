// owlcal fit-toe-in SETS.csv --out DIR: eye-pan servo maps (deg/us per eye) from stereo
// calibrations taken at known pulse widths (fitting/toe_in_servo_fit.h).
#include <cctype>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "apps/calibration_output.h"
#include "apps/command_registry.h"
#include "apps/output_folder.h"
#include "calib/csv.h"
#include "calib/image_pairs.h"
#include "calib/observation_io.h"
#include "calib/target_file.h"
#include "evaluation/range_images_calib.h"
#include "fitting/calibration_folder.h"
#include "fitting/format.h"
#include "fitting/toe_in_servo_fit.h"
#include "reports/table.h"
#include "reports/toe_in_tables.h"
#include "robot/robot_file.h"

namespace owlcal::apps {
namespace {

namespace fs = std::filesystem;

struct FitToeInOptions {
  std::string csv, out, target, robot_file, scale = "auto";
  bool mirror = false, swap = false, side_by_side = false;
};

struct SetRow {
  std::string path;
  double rx = 0, ry = 0, lx = 0, ly = 0;
};

// SETS.csv (calib/csv.h, header by name, case-insensitive): a path column (calibration, set,
// path or folder) and Rx, Ry, Lx, Ly (or rx_us ...) in microseconds, 1-10000. Paths are relative to
// the CSV's folder. Errors name path:line and the column.
std::vector<SetRow> ReadSetsCsv(const std::string& path) {
  const calib::CsvTable t = calib::CsvTable::Read(path, {.trim = true});
  auto lower = [](std::string h) {
    for (char& ch : h) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    return h;
  };
  std::string c_path, c[4];
  const char* servo[4] = {"rx", "ry", "lx", "ly"};
  for (const std::string& name : t.Header()) {
    const std::string h = lower(name);
    if (h == "calibration" || h == "set" || h == "path" || h == "folder") {
      if (!c_path.empty()) throw std::runtime_error(path + ":1: two path columns, " + c_path + " and " + name);
      c_path = name;
    }
    for (int k = 0; k < 4; ++k) {
      if (h != servo[k] && h != std::string(servo[k]) + "_us") continue;
      if (!c[k].empty()) throw std::runtime_error(path + ":1: two " + servo[k] + " columns, " + c[k] + " and " + name);
      c[k] = name;
    }
  }
  if (c_path.empty() || c[0].empty() || c[1].empty() || c[2].empty() || c[3].empty())
    throw std::runtime_error(path +
                             ":1: header needs calibration (a calibration folder, results.json, an image folder "
                             "or an observations CSV), Rx, Ry, Lx and Ly");
  std::vector<SetRow> rows;
  const fs::path base = fs::path(path).parent_path();
  for (size_t i = 0; i < t.NumRows(); ++i) {
    const std::string& cell = t.Text(i, c_path);
    if (cell.empty()) throw std::runtime_error(t.Where(i) + ": column " + c_path + " is empty");
    SetRow r;
    r.path = fs::path(cell).is_absolute() ? cell : (base / cell).string();
    // A servo pulse width in microseconds (the Owl's servos take 500-2500 us).
    r.rx = t.Number(i, c[0], 1, 10000);
    r.ry = t.Number(i, c[1], 1, 10000);
    r.lx = t.Number(i, c[2], 1, 10000);
    r.ly = t.Number(i, c[3], 1, 10000);
    rows.push_back(r);
  }
  if (rows.empty()) throw std::runtime_error(path + ": no sets (header only)");
  return rows;
}

// The stereo result of one set: read (results.json, or a folder holding one, only when its
// folder holds one run: fitting/calibration_folder.h) or calibrated here (an observations CSV, or
// a folder of image pairs with --target), written to set_dir with this run's id.
fitting::CalibrationResult ResultOf(
    const SetRow& row, const FitToeInOptions& a, const std::string& run_id, const fs::path& set_dir, std::string* how) {
  const fs::path p(row.path);
  if (p.extension() == ".json") {
    fitting::CheckOneRunOfPath(p.string());
    *how = "read";
    return fitting::ReadResultJson(p.string());
  }
  if (fs::is_directory(p) && fs::exists(p / "results.json")) {
    fitting::CheckOneRunOfPath(p.string());
    *how = "read";
    return fitting::ReadResultJson((p / "results.json").string());
  }
  std::vector<calib::CornerObservation> obs;
  fitting::StereoFitOptions fo;
  if (p.extension() == ".csv") {
    obs = calib::ReadObservationsCsv(p.string());
    fo.length_unit = "m";
    if (!a.target.empty()) fo.length_unit = calib::LoadTargetFileWithUnit(a.target).unit;
    *how = "calibrated from observations";
  } else if (fs::is_directory(p)) {
    if (a.target.empty())
      throw UsageError(row.path + " is an image folder: give --target so its sets can be calibrated");
    const calib::TargetFile target = calib::LoadTargetFileWithUnit(a.target);
    calib::ImagePairOptions po;
    po.mirror = a.mirror;
    po.swap = a.swap;
    po.side_by_side = a.side_by_side;
    const auto set = calib::DetectImagePairs(calib::ListImagePairs(p.string(), po), po, target.target, {});
    obs = set.observations;
    fo.width = set.width;
    fo.height = set.height;
    fo.length_unit = target.unit;
    *how = "calibrated from images";
  } else {
    throw std::runtime_error(row.path +
                             ": neither results.json, a calibration folder, an observations CSV nor an "
                             "image folder");
  }
  evaluation::ImageSetCalibration c = evaluation::CalibrateImageSet(obs, fo);
  StampRun(run_id, &c.result);
  c.result.inputs["source"] = row.path;
  fs::create_directories(set_dir);
  fitting::WriteResultJson(c.result, (set_dir / "results.json").string());
  *how += " (" + (set_dir / "results.json").string() + ", verdict " + c.set_verdict.status + ")";
  return c.result;
}

int RunFitToeIn(const FitToeInOptions& a) {
  fitting::ToeInFitOptions o;
  if (a.scale == "auto")
    o.scale_mode = fitting::ScaleMode::kAuto;
  else if (a.scale == "per-eye")
    o.scale_mode = fitting::ScaleMode::kPerEye;
  else if (a.scale == "common")
    o.scale_mode = fitting::ScaleMode::kCommon;
  else
    throw UsageError("--scale = '" + a.scale + "': use auto, per-eye or common");
  if (!a.robot_file.empty()) {
    const auto robot = robot::LoadRobotFile(a.robot_file);
    o.rx_direction = robot.servos[models::kRx].direction;
    o.lx_direction = robot.servos[models::kLx].direction;
  }
  const auto rows = ReadSetsCsv(a.csv);
  for (size_t i = 0; i < rows.size(); ++i)
    CheckInputOutsideRun(a.out, rows[i].path, a.csv + " row " + std::to_string(i + 1) + ":");
  // The folder holds this run alone (apps/output_folder.h): sets/ of an earlier run with more
  // sets go too, and a folder that is not owlcal's is refused before any set is calibrated.
  const std::string run_id = StartRun(a.out, [](const std::string& m) { std::cout << m << "\n"; });
  const fs::path out(a.out);
  std::vector<fitting::ToeInSet> sets;
  for (size_t i = 0; i < rows.size(); ++i) {
    fitting::ToeInSet s;
    std::string how;
    try {
      const auto result = ResultOf(rows[i], a, run_id, out / "sets" / std::to_string(i), &how);
      s = fitting::ToeInSetFromResult(result, rows[i].path);
    } catch (const UsageError&) {
      throw;
    } catch (const std::exception& e) {
      s.name = rows[i].path;
      s.message = e.what();  // a row with its reason, counted below: never a silent skip
      how = "failed";
    }
    s.rx_us = rows[i].rx;
    s.ry_us = rows[i].ry;
    s.lx_us = rows[i].lx;
    s.ly_us = rows[i].ly;
    std::cout << rows[i].path << ": " << how << (s.ok ? "" : "; not used: " + s.message) << "\n";
    sets.push_back(s);
  }
  const fitting::ToeInServoFit fit = fitting::FitToeIn(sets, o);
  const std::string md = reports::ToeInMarkdown(sets, fit);
  reports::WriteTextFile((out / "toe_in_fit.md").string(), md);
  reports::WriteTextFile((out / "toe_in_sets.csv").string(), reports::ToeInSetsCsv(sets, fit));
  fitting::CalibrationResult r;
  r.parameters = fit.parameters;
  r.warnings = fit.notes;
  r.inputs = {{"sets_csv", a.csv}, {"scale_mode", a.scale}, {"robot_file", a.robot_file}};
  StampRun(run_id, &r);
  r.diagnostics = {{"chi2", fit.chi2},
                   {"dof", fit.dof},
                   {"chi2_per_dof", fit.chi2_per_dof},
                   {"rms_residual_deg", fit.rms_residual_deg},
                   {"per_eye", fit.per_eye},
                   {"num_sets", fit.num_sets},
                   {"message", fit.message}};
  fitting::WriteResultJson(r, (out / "results.json").string());
  std::cout << md << "\nwrote " << a.out << ": toe_in_fit.md toe_in_sets.csv results.json\n";
  int used = 0;
  for (const auto& s : sets) used += s.ok;
  return fit.ok && used == static_cast<int>(sets.size()) ? kExitOk : kExitFailed;
}

const bool kFitToeInRegistered = RegisterCommand(
    "fit-toe-in",
    "Eye-pan servo maps (deg/us per eye, sigma including the scatter between sets, chi2/dof) from stereo\n"
    "calibrations taken at known pulse widths. SETS.csv has a header with calibration, Rx, Ry, Lx, Ly; each\n"
    "calibration is a results.json, a folder holding one, an observations CSV, or a folder of image pairs\n"
    "(calibrated here; needs --target). The relative yaw between the cameras of each set is fitted as\n"
    "yaw = c + k_L Lx - k_R Rx. Writes toe_in_fit.md, toe_in_sets.csv, results.json and sets/N/results.json.",
    [](CLI::App* cmd) {
      auto o = std::make_shared<FitToeInOptions>();
      cmd->add_option("sets", o->csv, "CSV of calibration,Rx,Ry,Lx,Ly (paths relative to the CSV)")
          ->required()
          ->check(CLI::ExistingFile);
      cmd->add_option("--out", o->out, "output folder")->required();
      cmd->add_option("--target", o->target, "target file, for sets given as image folders")->check(CLI::ExistingFile);
      cmd->add_option("--robot-file", o->robot_file, "robot file: the Rx / Lx directions")->check(CLI::ExistingFile);
      cmd->add_option("--scale", o->scale, "auto (per eye when the sets separate the eyes), per-eye or common")
          ->capture_default_str();
      cmd->add_flag("--mirror", o->mirror, "image folders are mirrored (see calibrate-images)");
      cmd->add_flag("--swap", o->swap, "image folders have the eyes swapped");
      cmd->add_flag("--side-by-side", o->side_by_side, "image folders hold 1280x480 side-by-side frames");
      return [o] { return RunFitToeIn(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
