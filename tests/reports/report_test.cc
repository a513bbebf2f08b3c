#include "reports/report.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <sstream>

#include <gtest/gtest.h>

#include "evaluation/truth_compare.h"
#include "reports/figures.h"
#include "reports/gnuplot_figure.h"
#include "reports/table.h"

namespace owlcal::reports {
namespace report_test {

std::string Slurp(const std::string& path) {
  std::ifstream f(path);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

std::string TempDir(const std::string& name) {
  const char* keep = std::getenv("OWLCAL_KEEP_REPORT");
  const std::string dir = keep ? std::string(keep) + "/" + name
                               : (std::filesystem::temp_directory_path() / ("owlcal_report_test_" + name)).string();
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

fitting::Parameter P(const std::string& n, double v, double s, const std::string& unit) {
  fitting::Parameter p;
  p.name = n;
  p.value = v;
  p.sigma = s;
  p.unit = unit;
  return p;
}

// A complete synthetic run: head with servo maps and sigmas, truth, ranging, steps, limits,
// residuals and coverage.
ReportData DemoData() {
  ReportData d;
  d.config = models::DefaultRobotConfig();
  models::HeadModel truth = models::NominalHeadModel(d.config);
  truth.servo_params[models::kRx] = {1540, 0.110, 0.6, -0.4, 1.0};
  truth.servo_params[models::kLx] = {1550, 0.116, -0.3, 0.5, 1.0};
  for (int e = 0; e < 2; ++e) truth.intrinsics[e].params = {580, 580, 321, 238, -0.12, 0.06, 0.001, -0.0005, 0};
  models::HeadModel est = truth;
  est.servo_params[models::kRx][0] += 0.3;
  est.servo_params[models::kLx][1] += 0.0004;
  d.truth = truth;
  d.result.software_version = "test";
  d.result.head = est;
  d.result.cameras[0] = est.intrinsics[0];
  d.result.cameras[1] = est.intrinsics[1];
  for (int s = 0; s < models::kNumServos; ++s) {
    const std::string n = std::string("servo.") + models::kServoNames[s];
    d.result.Set(P(n + ".centre_us", est.servo_params[s][0], 0.4, "us"));
    d.result.Set(P(n + ".deg_per_us", est.servo_params[s][1], 0.0005, "deg/us"));
    d.result.Set(P(n + ".quad_deg", est.servo_params[s][2], 0.2, "deg"));
    d.result.Set(P(n + ".cubic_deg", est.servo_params[s][3], 0.2, "deg"));
  }
  fitting::Parameter neck = P("servo.Neck.centre_us", 1530, NAN, "us");
  neck.determined = false;
  neck.note = "held at the robot file's centre (gauge)";
  d.result.Set(neck);
  d.result.Set(P("head.ipd_mm", 65.2, 0.3, "mm"));
  d.result.Set(P("left.fx", 580.4, 0.5, "px"));
  d.result.Set(P("right.fx", 580.1, 0.5, "px"));
  d.result.Set(P("right.cx", 321.0, 0.7, "px"));
  d.result.warnings.push_back("k3 not determined: all views fronto-parallel");
  d.result.summaries.push_back({"head", "CONVERGENCE", "ok", 100, 10, 12, 1.5, 0.15, 2000, 3, true});
  d.result.diagnostics["intrinsics"]["left"]["view_rms_px"] = {0.12, 0.15, 0.11, 0.3};
  d.result.diagnostics["intrinsics"]["right"]["view_rms_px"] = {0.13, 0.14, 0.12, 0.16};
  evaluation::FillTruth(evaluation::IntrinsicsTruthValues(truth), &d.result);
  std::map<std::string, double> servo_truth;
  for (int s = 0; s < models::kNumServos; ++s)
    servo_truth[std::string("servo.") + models::kServoNames[s] + ".centre_us"] = truth.servo_params[s][0];
  servo_truth["head.ipd_mm"] = 65.0;
  evaluation::FillTruth(servo_truth, &d.result);

  std::vector<evaluation::Fixation> fixations;
  int i = 0;
  for (double dist : {0.25, 0.5, 0.75, 1.0, 1.25, 1.5}) {
    auto f = evaluation::SyntheticFixation(truth, Eigen::Vector3d(0.02, 0, dist + 0.03), 1530);
    if (!f) continue;
    f->index = i++;
    fixations.push_back(*f);
  }
  std::vector<double> theory;
  for (double x = 0.2; x <= 2.0001; x += 0.05) theory.push_back(x);
  d.ranging = evaluation::EvaluateRanging(est,
                                          fitting::CovarianceFromResult(d.result, evaluation::RangingParameterNames()),
                                          d.config,
                                          fixations,
                                          {},
                                          theory);
  d.gains = fitting::MakeGainStudy(3);
  for (double k : {0.05, 0.1, 0.2, 0.3}) {
    StepTrace t;
    t.gain = k;
    t.amplitude_deg = 10;
    t.eye_axis = "right pan";
    const auto y = fitting::SimulateDelayedPLoop(k, 3, 90);
    for (size_t n = 0; n < y.size(); ++n) {
      t.t_s.push_back(n / 30.0);
      t.y.push_back(y[n] + 0.003 * std::sin(n));
    }
    fitting::StepInfoOptions o;
    o.y_init = 0.0;
    o.y_final = 1.0;
    t.info = fitting::ComputeStepInfo(t.t_s, t.y, o);
    t.residual_px = 0.4;
    d.steps.push_back(t);
  }
  d.limits = evaluation::EvaluateLimits(d.config,
                                        {{models::kRx, false, 1230, evaluation::LimitCause::kEndStop},
                                         {models::kRx, true, 1890, evaluation::LimitCause::kConfigured},
                                         {models::kLx, false, 1180, evaluation::LimitCause::kConfigured},
                                         {models::kLx, true, 1800, evaluation::LimitCause::kSocketRim}},
                                        &est);
  std::mt19937 rng(3);
  std::normal_distribution<double> n01;
  std::uniform_real_distribution<double> ux(20, 620), uy(20, 460);
  for (int k = 0; k < 400; ++k) {
    const int eye = k % 2;
    const double x = ux(rng), y = uy(rng);
    d.residuals.push_back({eye, k / 20, x, y, 0.15 * n01(rng), 0.15 * n01(rng)});
    d.coverage.push_back({eye, x, y});
  }
  // Views with names and board outlines (the 3D pose view); one view much worse than the rest.
  for (int e = 0; e < 2; ++e)
    for (int k = 0; k < 12; ++k) {
      d.views.push_back(
          {e, k, "intrinsics frame " + std::to_string(k), (e == 0 && k == 7) ? 0.9 : 0.12 + 0.01 * (k % 3), 54, 0});
      BoardOutline b;
      b.eye = e;
      b.frame = k;
      const Eigen::Vector3d c(-0.1 + 0.02 * k, -0.05, 0.4 + 0.05 * k);
      b.corners_in_cam = {
          c, c + Eigen::Vector3d(0.2, 0, 0.02), c + Eigen::Vector3d(0.2, 0.13, 0.02), c + Eigen::Vector3d(0, 0.13, 0)};
      d.boards.push_back(b);
    }
  fitting::StereoEstimate st;
  st.right_from_left.translation = Eigen::Vector3d(-0.065, 0, 0);
  d.result.stereo = st;
  d.settings = {{"command", "owlcal calibrate --out test"}, {"seed", 1}};
  return d;
}

// What calibrate-images has: cameras, stereo, residuals, views; no robot, servo maps, ranging,
// steps, gains, limits or truth.
ReportData ImagesOnlyData() {
  const ReportData full = DemoData();
  ReportData d;
  d.result.software_version = "test";
  d.result.cameras[0] = full.result.cameras[0];
  d.result.cameras[1] = full.result.cameras[1];
  d.result.stereo = full.result.stereo;
  for (const auto& p : full.result.parameters)
    if (p.name.rfind("left.", 0) == 0) {
      fitting::Parameter q = p;
      q.truth.reset();
      d.result.Set(q);
    }
  d.residuals = full.residuals;
  d.coverage = full.coverage;
  d.views = full.views;
  d.boards = full.boards;
  d.config.name = "none (calibration from images)";
  d.settings = {{"command", "owlcal calibrate-images"}, {"images", "kit"}, {"robot", "none"}};
  return d;
}

TEST(Report, EvaluationJsonRoundTrips) {
  const ReportData d = DemoData();
  ReportData back;
  EvaluationFromJson(EvaluationToJson(d), &back);
  ASSERT_TRUE(back.ranging);
  EXPECT_EQ(back.ranging->rows.size(), d.ranging->rows.size());
  EXPECT_DOUBLE_EQ(back.ranging->rows[2].range_m, d.ranging->rows[2].range_m);
  ASSERT_TRUE(back.limits);
  EXPECT_EQ(back.limits->servos[models::kRx].min_cause, evaluation::LimitCause::kEndStop);
  EXPECT_EQ(back.steps.size(), 4u);
  EXPECT_EQ(back.steps[1].info.settling_index, d.steps[1].info.settling_index);
  ASSERT_TRUE(back.gains && back.gains->fastest);
  EXPECT_DOUBLE_EQ(back.gains->fastest->gain, d.gains->fastest->gain);
  ASSERT_TRUE(back.truth);
  EXPECT_DOUBLE_EQ(back.truth->servo_params[models::kRx][0], 1540);
  EXPECT_EQ(back.residuals.size(), 400u);
  EXPECT_EQ(back.config.servos[models::kLy].direction, -1);
  ASSERT_EQ(back.views.size(), d.views.size());
  EXPECT_EQ(back.views[7].name, "intrinsics frame 7");
  ASSERT_EQ(back.boards.size(), d.boards.size());
  EXPECT_DOUBLE_EQ(back.boards[3].corners_in_cam[2].z(), d.boards[3].corners_in_cam[2].z());
}

TEST(Report, TablesCarryValuesSigmasAndTruth) {
  const ReportData d = DemoData();
  const std::vector<Table> tables = MakeTables(d);
  std::map<std::string, Table> by;
  for (const auto& t : tables) by[t.name] = t;
  for (const char* n : {"parameters",
                        "solver",
                        "undetermined",
                        "truth_comparison",
                        "ranging",
                        "ranging_summary",
                        "step_metrics",
                        "gain_study",
                        "limits"})
    EXPECT_TRUE(by.count(n)) << n;
  // The ranging notes that no row carries (what the size check compared with) are in the summary;
  // a fixation's own note is its row's reason, not repeated.
  {
    ReportData e = d;
    e.ranging->notes = {"fixation 7 not ranged: off target: demo", "size check: demo note"};
    std::string summary;
    for (const auto& t : MakeTables(e))
      if (t.name == "ranging_summary") summary = ToMarkdown(t);
    EXPECT_NE(summary.find("| note | size check: demo note |"), std::string::npos) << summary;
    EXPECT_EQ(summary.find("fixation 7"), std::string::npos) << summary;
  }
  // Whole-map comparison: Rx's centre is 0.3 us off at 0.110 deg/us, so every angle is about
  // 0.033 deg off; Lx's scale is off by 0.0004 deg/us, zero at its centre.
  ASSERT_TRUE(by.count("servo_map_truth"));
  std::set<std::string> servos_seen;
  for (const auto& row : by["servo_map_truth"].rows) {
    servos_seen.insert(row[0]);
    if (row[0] == "Rx") {
      EXPECT_NEAR(std::stod(row[2]), 0.033, 0.002) << ToCsv(by["servo_map_truth"]);
      EXPECT_NEAR(std::abs(std::stod(row[4])), 0.033, 0.002);
    }
    if (row[0] == "Ry") {
      EXPECT_LT(std::stod(row[2]), 1e-9);
    }
  }
  EXPECT_TRUE(servos_seen.count("Rx") && servos_seen.count("Ry")) << ToCsv(by["servo_map_truth"]);
  const std::string md = ToMarkdown(by["parameters"]);
  EXPECT_NE(md.find("| servo.Rx.centre_us | 1540.30 | 0.4 | \u00b5s | yes | 1540 | 0.3 | 0.75 |"), std::string::npos)
      << md;
  const std::string tex = ToLatex(by["parameters"]);
  EXPECT_NE(tex.find("servo.Rx.centre\\_us"), std::string::npos);
  EXPECT_NE(tex.find("\\toprule"), std::string::npos);
  EXPECT_NE(tex.find("\\num{1540.30}"), std::string::npos);
  const std::string und = ToCsv(by["undetermined"]);
  EXPECT_NE(und.find("servo.Neck.centre_us,held at the robot file's centre (gauge)"), std::string::npos) << und;
  // The d = 3 control facts appear in the gain table.
  const std::string gains = ToCsv(by["gain_study"]);
  EXPECT_NE(gains.find("K_crit = 2 sin(pi / (2 (2d + 1))),0.445"), std::string::npos) << gains;
  EXPECT_NE(gains.find("fastest stable gain,0.13"), std::string::npos) << gains;
}

TEST(Report, WritesASelfContainedPageWithEveryFigure) {
  std::string term;
  const bool have_gnuplot = GnuplotAvailable(&term);
  const ReportData d = DemoData();
  const std::string dir = TempDir("full");
  const ReportOutput out = WriteReport(d, dir);
  for (const auto& w : out.warnings) ADD_FAILURE() << w;
  // Every figure the lab report needs.
  const std::vector<std::string> expected = {"view_rms",
                                             "residual_field_left",
                                             "residual_field_right",
                                             "residual_hist_left",
                                             "residual_hist_right",
                                             "uncertainty_left",
                                             "uncertainty_right",
                                             "poses_3d",
                                             "distortion_left",
                                             "coverage",
                                             "servo_maps",
                                             "servo_rx_deviation",
                                             "range_error",
                                             "step_responses",
                                             "settling_vs_gain",
                                             "limits"};
  const std::string html = Slurp(out.index_html);
  for (const auto& name : expected) {
    EXPECT_TRUE(std::find(out.figures.begin(), out.figures.end(), name) != out.figures.end()) << name;
    for (const char* ext : {".csv", ".dat", ".gp"})
      EXPECT_TRUE(std::filesystem::exists(dir + "/figures/" + name + ext)) << name << ext;
    // The tidy CSV: one header row starting with "series", then one observation per row.
    const std::string csv = Slurp(dir + "/figures/" + name + ".csv");
    EXPECT_EQ(csv.rfind("series,", 0), 0u) << name;
    EXPECT_EQ(csv.find('#'), std::string::npos) << name;
    EXPECT_EQ(csv.find("\n\n"), std::string::npos) << name;
    if (have_gnuplot) {
      EXPECT_GT(std::filesystem::file_size(dir + "/figures/" + name + ".png"), 5000u) << name;
      EXPECT_NE(Slurp(dir + "/figures/" + name + ".svg").find("<svg"), std::string::npos) << name;
      EXPECT_EQ(Slurp(dir + "/figures/" + name + ".pdf").rfind("%PDF", 0), 0u) << name;
      // Embedded: the page alone shows it.
      const size_t at = html.find("<figure id=\"fig-" + name + "\">");
      ASSERT_NE(at, std::string::npos) << name;
      EXPECT_EQ(html.compare(html.find("<img", at), 32, "<img src=\"data:image/png;base64,"), 0) << name;
    }
  }
  // Self-contained: no image, script or stylesheet comes from a file.
  EXPECT_EQ(html.find("src=\"../"), std::string::npos);
  EXPECT_EQ(html.find("<link"), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos);
  // A one-screen summary first, then the lab-report sections; a print stylesheet.
  const size_t summary = html.find("class=\"summary\""), method = html.find("id=\"method\""),
               results = html.find("id=\"results\""), discussion = html.find("id=\"discussion\"");
  ASSERT_NE(summary, std::string::npos);
  EXPECT_LT(summary, method);
  EXPECT_LT(method, results);
  EXPECT_LT(results, discussion);
  EXPECT_NE(html.find("class=\"verdict"), std::string::npos);
  EXPECT_NE(html.find("What to do next"), std::string::npos);
  EXPECT_NE(html.find("intrinsics frame 7"), std::string::npos) << "the worst view is named";
  EXPECT_NE(html.find("@media print"), std::string::npos);
  EXPECT_NE(html.find("thead{display:table-header-group}"), std::string::npos);
  for (const char* sec : {"Vergence ranging", "Step response and gain", "Servo limits", "Ground-truth comparison"})
    EXPECT_NE(html.find(sec), std::string::npos) << sec;
  EXPECT_NE(html.find("servo.Neck.centre_us"), std::string::npos);
  EXPECT_NE(html.find("owlcal calibrate --out test"), std::string::npos);
  // No raw JSON dump, units a reader expects, no numerical noise printed as a value.
  EXPECT_EQ(html.find("<pre>"), std::string::npos);
  EXPECT_EQ(html.find("+-"), std::string::npos);
  EXPECT_EQ(html.find(" sigma"), std::string::npos);
  EXPECT_NE(html.find("\u00b5s"), std::string::npos);
  EXPECT_NE(html.find("\u00b12\u03c3"), std::string::npos);
  EXPECT_EQ(html.find("e-17"), std::string::npos);
  // Text columns left, numbers right.
  EXPECT_NE(html.find("<td>servo.Rx.centre_us</td><td class=\"num\">1540.30</td>"), std::string::npos);
  for (const char* ext : {".csv", ".md", ".tex"})
    EXPECT_TRUE(std::filesystem::exists(dir + "/tables/ranging" + std::string(ext)));
}

TEST(Report, ImagesOnlyReportShowsOnlySectionsWithData) {
  const ReportData d = ImagesOnlyData();
  const std::string dir = TempDir("images");
  const ReportOutput out = WriteReport(d, dir);
  EXPECT_EQ(out.index_html, dir + "/report/index.html");
  const std::string html = Slurp(out.index_html);
  for (const char* absent : {"Vergence ranging",
                             "Step response",
                             "Servo limits",
                             "Ground-truth",
                             "Servo maps and head",
                             "robot file",
                             "guide-owl"})
    EXPECT_EQ(html.find(absent), std::string::npos) << absent;
  EXPECT_NE(html.find("No robot"), std::string::npos);
  EXPECT_NE(html.find("Camera intrinsics"), std::string::npos);
  EXPECT_NE(html.find("fig-view_rms"), std::string::npos);
  EXPECT_NE(html.find("fig-poses_3d"), std::string::npos);
  for (const auto& f : out.figures) {
    EXPECT_EQ(f.rfind("servo", 0), std::string::npos) << f;
    EXPECT_NE(f, "range_error");
    EXPECT_NE(f, "settling_vs_gain");
  }
}

TEST(Report, SteadyStateErrorIsWhatTheTrialLeftUndone) {
  StepTrace t;
  for (int k = 0; k < 60; ++k) {
    t.t_s.push_back(k / 30.0);
    t.y.push_back(k < 20 ? k / 20.0 * 0.9 : 0.9);  // stops 10 % short: not settled
  }
  fitting::StepInfoOptions o;
  o.y_init = 0.0;
  o.y_final = 1.0;
  t.info = fitting::ComputeStepInfo(t.t_s, t.y, o);
  EXPECT_FALSE(t.info.settled);
  EXPECT_NEAR(SteadyStateError(t), 0.1, 1e-12);
  ReportData d;
  d.steps.push_back(t);
  for (const auto& tab : MakeTables(d))
    if (tab.name == "step_metrics") {
      EXPECT_EQ(tab.rows[0][9], "10") << ToCsv(tab);
    }
}

TEST(Report, LatexTablesCompile) {
  const ReportData d = DemoData();
  const std::string dir = TempDir("latex");
  WriteReport(d, dir, {false, "test"});
  std::ostringstream doc;
  doc << "\\documentclass{article}\n\\usepackage[T1]{fontenc}\n\\usepackage[utf8]{inputenc}\n"
         "\\usepackage{textcomp,booktabs,longtable,siunitx}\n\\usepackage[a4paper,landscape,margin=1cm]{geometry}\n"
         "\\begin{document}\n\\scriptsize\n";
  int n = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir + "/tables"))
    if (e.path().extension() == ".tex") {
      const std::string tex = Slurp(e.path().string());
      EXPECT_NE(tex.find("\\begin{longtable}"), std::string::npos) << e.path();
      EXPECT_NE(tex.find("\\endhead"), std::string::npos) << e.path();
      doc << "\\input{" << e.path().filename().string() << "}\n";
      ++n;
    }
  doc << "\\end{document}\n";
  EXPECT_GE(n, 8);
  // Escaping: |relative error| and units survive as text.
  const std::string ranging = Slurp(dir + "/tables/ranging_summary.tex");
  EXPECT_NE(ranging.find("\\textbar{}relative error\\textbar{}"), std::string::npos) << ranging;
  EXPECT_NE(Slurp(dir + "/tables/limits.tex").find("\\textmu{}s"), std::string::npos);
  EXPECT_NE(Slurp(dir + "/tables/parameters.tex").find("\\num{"), std::string::npos);
  WriteTextFile(dir + "/tables/all.tex", doc.str());
  int st = std::system("command -v pdflatex >/dev/null 2>&1");
  if (st != 0) GTEST_SKIP() << "no TeX engine (pdflatex) installed: the LaTeX tables were written but not compiled";
  st = std::system(
      ("cd " + dir + "/tables && pdflatex -interaction=nonstopmode -halt-on-error all.tex >latex.log 2>&1").c_str());
  EXPECT_EQ(st, 0) << Slurp(dir + "/tables/latex.log").substr(0, 4000);
  EXPECT_TRUE(std::filesystem::exists(dir + "/tables/all.pdf"));
}

TEST(Report, FigureCsvHasOneBlockPerSeries) {
  Figure f{"demo", "Demo", "x [m]", "y [%]", {}, {}, "top left"};
  f.series.push_back({"a", "lines", "1:2", {"x", "y"}, {{1, 2}, {3, NAN}}});
  f.series.push_back({"b", "points", "1:2", {"x", "y"}, {}});
  const std::string dat = FigureData(f);
  EXPECT_NE(dat.find("# series 0: a\n# x,y\n1,2\n3,NaN\n\n\n# series 1: b"), std::string::npos) << dat;
  f.series.push_back({"c, quoted", "lines", "1:2", {"x", "z"}, {{5, 6}}});
  EXPECT_EQ(FigureCsv(f), "series,x,y,z\na,1,2,\na,3,,\n\"c, quoted\",5,,6\n");
  const std::string gp = GnuplotScript(f, "png");
  EXPECT_NE(gp.find("index 1 using 1:2 with points title \"b\""), std::string::npos) << gp;
  EXPECT_THROW(WriteFigure(Figure{"Bad Name", "", "", "", {}, {}, ""}, "/tmp", false), std::invalid_argument);
}

}  // namespace report_test
}  // namespace owlcal::reports
