#include "fitting/vergence_log_fit.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <random>

#include <gtest/gtest.h>

#include "owlcal_version.h"
#include "reports/vergence_log_tables.h"
#include "tests/shared_data.h"

namespace owlcal::fitting {
namespace vergence_log_test {

using ::owlcal::test_data::SharedData;

// Synthetic log from known maps, PWM rounded to 1 us like a real log.
std::vector<VergenceLogRow> SyntheticLog(const VergenceMaps& truth, int runs, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0, 0.7);
  std::vector<VergenceLogRow> rows;
  for (int r = 0; r < runs; ++r) {
    for (int cm = 10; cm <= 100; cm += 10) {
      double rx, lx;
      truth.PredictPwm(cm / 100.0, r, &rx, &lx);
      rows.push_back({r + 1, cm / 100.0, std::round(rx + noise(rng)), std::round(lx + noise(rng))});
    }
  }
  return rows;
}

TEST(VergenceLogFit, RecoversMapsAndDatumFromSyntheticLogWithinSigma) {
  VergenceMaps truth;
  truth.rx_centre_us = 1452;
  truth.rx_us_per_deg = 10.1;
  truth.lx_centre_us = 1421;
  truth.lx_us_per_deg = 11.2;
  truth.ipd_m = 0.065;
  truth.datum_offset_m = 0.045;
  truth.run_bearing_rad = {0, 0.02, -0.015};
  const auto rows = SyntheticLog(truth, 3, 7);
  VergenceFitOptions o;
  const VergenceLogFit fit = FitVergenceLog(rows, o);
  ASSERT_TRUE(fit.summary.usable) << fit.summary.message;
  EXPECT_FALSE(fit.ipd_free) << "IPD should not be separable from the scales";
  auto check = [&](const std::string& name, double t) {
    for (const auto& p : fit.parameters) {
      if (p.name != name) continue;
      ASSERT_TRUE(p.determined) << name;
      EXPECT_LT(std::abs(p.value - t), 4 * p.sigma + 1e-9) << name << " = " << p.value << " +- " << p.sigma;
      EXPECT_GT(p.sigma, 0) << name;
      return;
    }
    ADD_FAILURE() << name << " missing";
  };
  check("servo.Rx.centre_us", truth.rx_centre_us);
  check("servo.Lx.centre_us", truth.lx_centre_us);
  check("servo.Rx.us_per_deg", truth.rx_us_per_deg);
  check("servo.Lx.us_per_deg", truth.lx_us_per_deg);
  check("vergence.datum_mm", truth.datum_offset_m * 1000);
  EXPECT_NEAR(fit.residual_sigma_us, 0.8, 0.3);
}

TEST(VergenceLogFit, FixedConstantMethodReproducesTheStudentsSheet) {
  // Run 1, 30 cm and 10 cm rows of noble2020 with the sheet's own estimates.
  FixedConstantVergence f;
  EXPECT_NEAR(*f.Distance(1385, 1485) * 100, 31.647, 0.01);
  EXPECT_NEAR(*f.Distance(1310, 1595) * 100, 10.051, 0.01);
  EXPECT_FALSE(f.Distance(1445, 1430).has_value()) << "parallel gaze has no fix";
}

TEST(VergenceLogFit, Noble2020LeaveOneOutBeatsFixedConstants) {
  const std::string path = SharedData() + "/owl-real/noble2020-vergence-range/vergence_runs.csv";
  // Two distance-like columns (actual_distance_cm, sheet_estimate_cm): the true one is named.
  VergenceColumnRequest columns;
  columns.distance = "actual_distance_cm";
  const auto rows = ReadVergenceLogCsv(path, columns);
  ASSERT_EQ(rows.size(), 30u);
  VergenceFitOptions o;
  const VergenceLogFit fit = FitVergenceLog(rows, o);
  ASSERT_TRUE(fit.summary.usable) << fit.summary.message;
  // The comparison uses THIS robot's constants, from its robot file (the sheet's values).
  models::RobotConfig robot = models::DefaultRobotConfig();
  robot.servos[models::kRx].centre_us = 1445;
  robot.servos[models::kLx].centre_us = 1430;
  robot.servos[models::kRx].nominal_deg_per_us = robot.servos[models::kLx].nominal_deg_per_us = 1 / 10.73;
  const FixedConstantVergence sheet = FixedConstantVergence::FromRobot(robot, 0.030, "noble2020 robot file");
  EXPECT_NEAR(*sheet.Distance(1385, 1485) * 100, 31.647, 0.01);
  const LooSummary loo = LeaveOneOut(rows, o, fit, sheet);
  EXPECT_TRUE(loo.has_fixed);
  std::cout << reports::VergenceReportMarkdown(rows, fit, loo) << "\n" << reports::VergenceRowsCsv(rows, fit, loo);
  EXPECT_LT(loo.loo_mean_abs_rel, loo.fixed_mean_abs_rel);
  EXPECT_LT(loo.loo_median_abs_rel, loo.fixed_median_abs_rel);
  for (const auto& p : fit.parameters) {
    if (p.determined) {
      EXPECT_TRUE(std::isfinite(p.sigma) && p.sigma > 0) << p.name;
    }
  }
}

std::string WriteTemp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + "/" + name;
  std::ofstream(path) << text;
  return path;
}

std::string ErrorOf(const std::string& path, const VergenceColumnRequest& columns = {}) {
  try {
    ReadVergenceLogCsv(path, columns);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

// The trap: a log with the sheet's own estimate, the program's output and the
// true distance. Without --distance-column it is refused, naming all three and the option;
// named, the true distance is read and the other two are listed as ignored.
TEST(VergenceLogColumns, SeveralDistanceColumnsAreRefusedUnlessOneIsNamed) {
  const std::string path =
      WriteTemp("trap_vergence.csv",
                "run,sheet_calc_distance_mm,program_reported_distance_mm,actual_distance_mm,Rx,Lx\n"
                "1,101,98,100,1310,1595\n1,195,210,200,1355,1520\n");
  const std::string e = ErrorOf(path);
  EXPECT_NE(e.find(path), std::string::npos) << e;
  for (const char* c :
       {"sheet_calc_distance_mm", "program_reported_distance_mm", "actual_distance_mm", "--distance-column"})
    EXPECT_NE(e.find(c), std::string::npos) << c << " not in: " << e;
  VergenceColumnRequest req;
  req.distance = "actual_distance_mm";
  VergenceColumns used;
  const auto rows = ReadVergenceLogCsv(path, req, &used);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_DOUBLE_EQ(rows[0].true_distance_m, 0.100);
  EXPECT_DOUBLE_EQ(rows[1].true_distance_m, 0.200);
  EXPECT_EQ(used.distance_name, "actual_distance_mm");
  EXPECT_EQ(used.distance_unit, "mm");
  EXPECT_EQ(used.ignored, (std::vector<std::string>{"sheet_calc_distance_mm", "program_reported_distance_mm"}));
  EXPECT_NE(used.Describe().find("ignored: sheet_calc_distance_mm"), std::string::npos) << used.Describe();
  // The real noble2020 log has the same trap (actual_distance_cm, sheet_estimate_cm).
  const std::string noble = SharedData() + "/owl-real/noble2020-vergence-range/vergence_runs.csv";
  const std::string en = ErrorOf(noble);
  EXPECT_NE(en.find("sheet_estimate_cm"), std::string::npos) << en;
  EXPECT_NE(en.find("actual_distance_cm"), std::string::npos) << en;
}

TEST(VergenceLogColumns, ColumnsAreMappedExplicitly) {
  const std::string path = WriteTemp("renamed_vergence.csv", "trial,target_mm,right_pan,left_pan\n3,250,1400,1455\n");
  EXPECT_NE(ErrorOf(path).find("--rx-column"), std::string::npos) << ErrorOf(path);
  VergenceColumnRequest req;
  req.rx = "right_pan";
  req.lx = "LEFT_PAN";  // case-insensitive
  req.run = "trial";
  VergenceColumns used;
  const auto rows = ReadVergenceLogCsv(path, req, &used);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].run, 3);
  EXPECT_DOUBLE_EQ(rows[0].true_distance_m, 0.25);
  EXPECT_DOUBLE_EQ(rows[0].rx_us, 1400);
  EXPECT_DOUBLE_EQ(rows[0].lx_us, 1455);
  EXPECT_EQ(used.distance_name, "target_mm");  // the only distance-like column
  req.distance = "no_such_column";
  EXPECT_NE(ErrorOf(path, req).find("'no_such_column' is not a column"), std::string::npos) << ErrorOf(path, req);
  // A distance column without a unit needs --distance-unit.
  const std::string nounit = WriteTemp("nounit_vergence.csv", "distance,Rx,Lx\n25,1400,1455\n");
  EXPECT_NE(ErrorOf(nounit).find("--distance-unit"), std::string::npos) << ErrorOf(nounit);
  VergenceColumnRequest cm;
  cm.distance_unit = "cm";
  EXPECT_DOUBLE_EQ(ReadVergenceLogCsv(nounit, cm)[0].true_distance_m, 0.25);
}

// wilmot2019's logs have no header (estimate, true distance in mm) and no PWM at all.
TEST(VergenceLogColumns, HeaderlessLogIsRefusedWithWhatToAdd) {
  const std::string path =
      SharedData() + "/owl-real/wilmot2019-range-csv/vergence/2019-03-25_vergence_distance_measurements_10mm_steps.csv";
  const std::string e = ErrorOf(path);
  EXPECT_NE(e.find("not a header"), std::string::npos) << e;
  EXPECT_NE(e.find(path), std::string::npos) << e;
}

TEST(VergenceLogFit, ReaderNamesFileAndFieldOnBadInput) {
  const std::string path = ::testing::TempDir() + "/bad_vergence.csv";
  {
    std::ofstream f(path);
    f << "run,distance_cm,Rx,Lx\n1,10,13x0,1595\n";
  }
  try {
    ReadVergenceLogCsv(path);
    FAIL() << "no throw";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("Rx"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

std::string ReaderError(const std::string& text) {
  const std::string path = ::testing::TempDir() + "/hostile_vergence.csv";
  std::ofstream(path, std::ios::trunc) << text;
  try {
    ReadVergenceLogCsv(path);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

// Issue table "Crashes": a nan cell or a negative distance made fit-vergence segfault. The reader
// refuses each, naming the file, line and column.
TEST(VergenceLogFit, ReaderRefusesNanNegativeAndHugeValues) {
  const std::string path = ::testing::TempDir() + "/hostile_vergence.csv";
  const std::string head = "run,distance_cm,Rx,Lx\n1,10,1310,1595\n";
  EXPECT_EQ(ReaderError(head + "1,nan,1355,1520\n"),
            path + ":3: column distance_cm = 'nan' is not a finite decimal number");
  EXPECT_EQ(ReaderError(head + "1,-20,1355,1520\n"), path + ":3: column distance_cm = -20 is not positive");
  EXPECT_EQ(ReaderError(head + "1,0,1355,1520\n"), path + ":3: column distance_cm = 0 is not positive");
  EXPECT_EQ(ReaderError(head + "1,20,inf,1520\n"), path + ":3: column Rx = 'inf' is not a finite decimal number");
  EXPECT_EQ(ReaderError(head + "1,20,1355,1e300\n"), path + ":3: column Lx = 1e+300 is outside [0, 9999]");
  EXPECT_EQ(ReaderError(head + "1,20,1355\n"), path + ":3: 3 cells, the header has 4");
  EXPECT_EQ(ReaderError(head + "\"1\",\"20\",\"1355\",\"1520\"\n"), "");  // quoted cells are fine
}

TEST(VergenceLogFit, RefusesNonFiniteOrNonPositiveDistancesWithoutCrashing) {
  std::vector<VergenceLogRow> rows = SyntheticLog(VergenceMaps{}, 1, 3);
  for (double bad : {std::nan(""), -0.2, 0.0, HUGE_VAL}) {
    std::vector<VergenceLogRow> r = rows;
    r[4].true_distance_m = bad;
    EXPECT_THROW(FitVergenceLog(r, VergenceFitOptions{}), std::invalid_argument) << bad;
  }
  std::vector<VergenceLogRow> r = rows;
  r[2].lx_us = std::nan("");
  EXPECT_THROW(FitVergenceLog(r, VergenceFitOptions{}), std::invalid_argument);
}

// Issue table "Silent wrong results (5)": 30 identical rows gave +- 0.009 us (a pseudo-inverse
// covariance) and exit 0. One distance cannot separate a centre from a scale: not determined.
TEST(VergenceLogFit, IdenticalRowsDetermineNothingAndTheFitIsNotUsable) {
  const std::vector<VergenceLogRow> rows(30, VergenceLogRow{1, 0.30, 1400, 1480});
  const VergenceLogFit fit = FitVergenceLog(rows, VergenceFitOptions{});
  EXPECT_FALSE(fit.summary.usable);
  for (const Parameter& p : fit.parameters) {
    EXPECT_FALSE(p.determined) << p.name << " = " << p.value << " +- " << p.sigma;
    EXPECT_FALSE(std::isfinite(p.sigma)) << p.name;
  }
  bool said = false;
  for (const std::string& n : fit.notes) said = said || n.find("one distance") != std::string::npos;
  EXPECT_TRUE(said);
  // Two distances, still repeated: the centres and scales are determined again.
  std::vector<VergenceLogRow> two = rows;
  for (size_t i = 0; i < two.size(); i += 2) two[i] = {1, 0.80, 1430, 1452};
  VergenceFitOptions o;
  o.fit_datum = false;
  o.ipd_mode = IpdMode::kFixed;
  const VergenceLogFit fit2 = FitVergenceLog(two, o);
  EXPECT_TRUE(fit2.summary.usable) << fit2.summary.message;
}

// Regression: a log with the same PWM at every distance reported us_per_deg = 0.000 +- 0.051 as
// determined. An eye whose PWM does not follow the distance has no map: not determined, with a
// note, and the fit is not usable.
TEST(VergenceLogFit, ConstantPwmAtEveryDistanceDeterminesNoScale) {
  std::vector<VergenceLogRow> rows;
  for (int cm = 10; cm <= 100; cm += 10) rows.push_back({1, cm / 100.0, 1400, 1480});
  const VergenceLogFit fit = FitVergenceLog(rows, VergenceFitOptions{});
  EXPECT_FALSE(fit.summary.usable);
  for (const Parameter& p : fit.parameters) {
    if (p.name != "servo.Rx.us_per_deg" && p.name != "servo.Lx.us_per_deg") continue;
    EXPECT_FALSE(p.determined) << p.name << " = " << p.value << " +- " << p.sigma;
    EXPECT_NE(p.note.find("in every row"), std::string::npos) << p.note;
  }
  bool said = false;
  for (const std::string& n : fit.notes) said = said || n.find("Rx PWM is 1400.0 us in every row") != std::string::npos;
  EXPECT_TRUE(said);
  // One eye converging, the other fixed: that eye's scale alone is refused.
  std::vector<VergenceLogRow> one = SyntheticLog(VergenceMaps{}, 1, 9);
  for (auto& r : one) r.lx_us = 1480;
  const VergenceLogFit fit1 = FitVergenceLog(one, VergenceFitOptions{});
  EXPECT_FALSE(fit1.summary.usable);
  for (const Parameter& p : fit1.parameters) {
    if (p.name == "servo.Rx.us_per_deg") {
      EXPECT_TRUE(p.determined) << p.note;
    }
  }
}

// Regression: fit-vergence's leave-one-out refitted once per row, so its cost grew with the square
// of the rows (300 rows 3.6 s; 100,000 rows ran out of memory). A 3,000-row log is dealt into
// kMaxVergenceFolds folds and every row still gets a prediction from a fit without it.
TEST(VergenceLogFit, LongLogIsCrossValidatedInABoundedNumberOfFolds) {
  VergenceMaps truth;
  truth.rx_centre_us = 1452;
  truth.rx_us_per_deg = 10.1;
  truth.lx_centre_us = 1421;
  truth.lx_us_per_deg = 11.2;
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0, 0.7);
  std::vector<VergenceLogRow> rows;
  for (int i = 0; i < 3000; ++i) {
    const double d = 0.10 + 0.01 * (i % 91);
    double rx, lx;
    truth.PredictPwm(d, 0, &rx, &lx);
    rows.push_back({1, d, std::round(rx + noise(rng)), std::round(lx + noise(rng))});
  }
  VergenceFitOptions o;
  const VergenceLogFit fit = FitVergenceLog(rows, o);
  ASSERT_TRUE(fit.summary.usable) << fit.summary.message;
  EXPECT_NEAR(fit.maps.rx_us_per_deg, truth.rx_us_per_deg, 0.2);
  EXPECT_NEAR(fit.maps.lx_us_per_deg, truth.lx_us_per_deg, 0.2);
  const LooSummary loo = LeaveOneOut(rows, o, fit);
  EXPECT_EQ(loo.folds, static_cast<int>(kMaxVergenceFolds));
  ASSERT_EQ(loo.rows.size(), rows.size());
  for (size_t i = 0; i < loo.rows.size(); ++i) {
    EXPECT_EQ(loo.rows[i].row, static_cast<int>(i));
    ASSERT_TRUE(loo.rows[i].loo_m.has_value()) << i;
  }
  EXPECT_EQ(loo.loo_failures, 0);
  EXPECT_LT(loo.loo_median_abs_rel, 0.05);
  // A short log keeps one refit per row.
  const std::vector<VergenceLogRow> short_log(rows.begin(), rows.begin() + 40);
  const VergenceLogFit fit40 = FitVergenceLog(short_log, o);
  ASSERT_TRUE(fit40.summary.usable) << fit40.summary.message;
  EXPECT_EQ(LeaveOneOut(short_log, o, fit40).folds, 40);
  const std::string md = reports::VergenceReportMarkdown(rows, fit, loo);
  EXPECT_NE(md.find("dealt into 100 folds"), std::string::npos) << md;
  // A run id on every row would add a bearing per row: more than kMaxVergenceRuns runs are refused.
  std::vector<VergenceLogRow> many_runs = rows;
  for (size_t i = 0; i < many_runs.size(); ++i) many_runs[i].run = static_cast<int>(i % (kMaxVergenceRuns + 1));
  try {
    FitVergenceLog(many_runs, o);
    ADD_FAILURE() << "a log with " << kMaxVergenceRuns + 1 << " runs was fitted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("51 runs"), std::string::npos) << e.what();
  }
}

// Issue table "Silent wrong results (5)": NO_CONVERGENCE exited 0. It is not usable now, has no
// sigma, and the report prints no parameter value.
TEST(VergenceLogFit, NoConvergenceIsNotUsableAndReportsNoValues) {
  const std::vector<VergenceLogRow> rows = SyntheticLog(VergenceMaps{}, 2, 5);
  VergenceFitOptions o;
  o.max_iterations = 1;
  o.initial.rx_centre_us = 1700;  // far from the truth: one iteration cannot converge
  const VergenceLogFit fit = FitVergenceLog(rows, o);
  EXPECT_EQ(fit.summary.termination, "NO_CONVERGENCE");
  EXPECT_FALSE(fit.summary.usable);
  for (const Parameter& p : fit.parameters) EXPECT_FALSE(p.determined) << p.name;
  const std::string md = reports::VergenceReportMarkdown(rows, fit, LooSummary{});
  EXPECT_NE(md.find("no parameter is reported"), std::string::npos) << md;
  EXPECT_EQ(md.find("| servo.Rx.centre_us |"), std::string::npos) << md;
}

}  // namespace vergence_log_test
}  // namespace owlcal::fitting
