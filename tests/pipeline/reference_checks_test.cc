// The checks against references in calibrate's results (evaluation/reference_checks.h): the
// latency protocol's reading against the reading the virtual Owl's truth predicts, the
// alignment verdict against its stated tolerance, the field of view against the datasheet.
#include "evaluation/reference_checks.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "pipeline/calibrate.h"
#include "pipeline/calibrate_pipeline.h"
#include "protocols/dataset_tables.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "reports/report.h"
#include "sim/virtual_owl.h"

namespace owlcal::pipeline {
namespace reference_checks_test {
namespace fs = std::filesystem;

std::string TempDir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("owlcal_refcheck_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(p);
  return p.string();
}

// Runs one standard protocol on `owl` into a fresh folder.
std::string RunStandard(sim::VirtualOwl& owl, const std::string& protocol, const std::string& name) {
  protocols::RunOptions o;
  o.out_dir = TempDir(name);
  o.robot_spec = "sim";
  std::ostringstream progress;
  o.progress = &progress;
  const protocols::RunSummary s =
      protocols::RunProtocols({protocols::LoadProtocolFile(protocols::ResolveProtocolPath(protocol))}, owl, o);
  EXPECT_EQ(s.status, "complete") << s.message;
  return o.out_dir;
}

// The latency check's truth as calibrate takes it from a virtual Owl.
evaluation::LatencyTruth TruthOf(const sim::RobotTruth& t) { return LatencyTruthOf(t); }

nlohmann::json Checks(const std::map<std::string, std::string>& datasets,
                      const models::RobotConfig& config,
                      const std::optional<evaluation::LatencyTruth>& truth) {
  CalibratePipelineOptions o;
  o.config = config;
  o.latency_truth = truth;
  const evaluation::CalibrationRun run = CalibrateFromDatasets(datasets, o);
  EXPECT_TRUE(run.result.diagnostics.contains("reference_checks"));
  return run.result.diagnostics.value("reference_checks", nlohmann::json::object());
}

const nlohmann::json& Group(const nlohmann::json& latency, const std::string& servo) {
  for (const auto& g : latency.at("groups"))
    if (g.at("servo") == servo) return g;
  throw std::runtime_error("no latency group " + servo);
}

// The mean and sample standard deviation of the readings latency.csv holds.
std::pair<double, double> CsvMeanSigma(const std::string& dir) {
  std::vector<double> v;
  for (const auto& r : protocols::ReadLatencyCsv(dir))
    if (r.latency_ms) v.push_back(*r.latency_ms);
  double m = 0, ss = 0;
  for (double x : v) m += x / v.size();
  for (double x : v) ss += (x - m) * (x - m);
  return {m, std::sqrt(ss / (v.size() - 1))};
}

TEST(ReferenceChecks, LatencyReadingMatchesWhatTheTruthPredictsPerTrial) {
  // Two robots: the default with a clean global-shutter stream (StreamTruth's own defaults: 100 ms,
  // 4 ms eye offset), where every reading must land on the predicted frame, and a slower stream with
  // a rolling shutter and the right eye exposing first. (The default robot's own stream is a real
  // Owl's, with the rolling shutter: the second case.)
  for (int robot = 0; robot < 2; ++robot) {
    sim::VirtualOwlOptions vo;
    vo.truth = sim::DefaultRobotTruth();
    vo.truth->stream = sim::StreamTruth();
    if (robot == 1) {
      sim::RobotTruth t = sim::DefaultRobotTruth();
      t.stream = sim::MeasuredOwlStream();
      t.stream.latency_ms = 170;
      t.stream.eye_offset_ms = -6;
      t.servos[models::kRx].lag_s = 0.06;
      vo.truth = t;
    }
    sim::VirtualOwl owl(vo);
    const std::string dir = RunStandard(owl, "latency", "latency" + std::to_string(robot));
    const nlohmann::json l = Checks({{"latency", dir}}, owl.Config(), TruthOf(owl.Truth())).at("latency");
    const auto [mean, sigma] = CsvMeanSigma(dir);
    const nlohmann::json& all = Group(l, "all");
    EXPECT_EQ(all.at("num_trials"), 8);
    EXPECT_EQ(all.at("num_ok"), 8);
    EXPECT_EQ(all.at("num_with_truth"), 8);
    EXPECT_NEAR(all.at("mean_ms").get<double>(), mean, 1e-9);
    EXPECT_NEAR(all.at("sigma_ms").get<double>(), sigma, 1e-9);
    if (robot == 0) {
      // Every trial's reading is the predicted frame (the CSV keeps 0.01 ms).
      EXPECT_EQ(all.at("num_on_predicted_frame"), 8);
      EXPECT_LT(all.at("max_abs_trial_error_ms").get<double>(), 0.01) << l.dump(1);
      EXPECT_NEAR(all.at("truth_mean_ms").get<double>(), mean, 0.01);
    } else {
      // A 60 ms lag brings Rx's shift near the threshold at the predicted frame, and the rolling
      // shutter shears the image: a reading may come one frame late, never more.
      EXPECT_GE(all.at("num_on_predicted_frame").get<int>(), 6) << l.dump(1);
      EXPECT_LE(all.at("max_abs_trial_error_ms").get<double>(), 1000 / 30.0 + 0.01) << l.dump(1);
      EXPECT_EQ(Group(l, "Lx").at("num_on_predicted_frame"), 3);
      EXPECT_LT(Group(l, "Lx").at("max_abs_trial_error_ms").get<double>(), 0.01) << l.dump(1);
    }
    EXPECT_EQ(l.at("stream_latency_truth_ms"), owl.Truth().stream.latency_ms);
    EXPECT_EQ(Group(l, "Rx").at("num_trials"), 5);
    EXPECT_EQ(Group(l, "Lx").at("num_trials"), 3);
    // The reading is the stream latency plus the servo onset and the wait for an exposure: more
    // than the latency, by less than the onset bound plus one frame.
    EXPECT_GT(mean, owl.Truth().stream.latency_ms);
    EXPECT_LT(mean, owl.Truth().stream.latency_ms + 150);
    if (robot == 1) {
      // A wrong truth (the default stream's 100 ms) is off by the latency difference, per trial.
      evaluation::LatencyTruth wrong = TruthOf(owl.Truth());
      wrong.latency_ms = 100;
      const nlohmann::json w = Checks({{"latency", dir}}, owl.Config(), wrong).at("latency");
      EXPECT_NEAR(Group(w, "Lx").at("error_ms").get<double>(), 70, 0.01);
    }
  }
}

TEST(ReferenceChecks, LatencyHasNoTruthColumnOnARealRobotOrAnOlderDataset) {
  sim::VirtualOwl owl({});
  const std::string dir = RunStandard(owl, "latency", "latency_real");
  const nlohmann::json l = Checks({{"latency", dir}}, owl.Config(), std::nullopt).at("latency");
  EXPECT_TRUE(Group(l, "all").at("truth_mean_ms").is_null());
  EXPECT_TRUE(l.at("stream_latency_truth_ms").is_null());
  EXPECT_NEAR(Group(l, "all").at("mean_ms").get<double>(), CsvMeanSigma(dir).first, 1e-9);

  // A dataset from before command_ns: read, no truth, and said so.
  const std::string old = TempDir("latency_old");
  fs::create_directories(old);
  std::ofstream(old + "/latency.csv") << "step_index,trial,servo,amplitude_us,latency_ms,frames_waited,shift_px\n"
                                         "1,0,Rx,40,132.33,4,27.2\n1,1,Rx,40,,30,0.4\n";
  const nlohmann::json o = Checks({{"latency", old}}, owl.Config(), TruthOf(owl.Truth())).at("latency");
  const nlohmann::json& rx = Group(o, "Rx");
  EXPECT_EQ(rx.at("num_trials"), 2);
  EXPECT_EQ(rx.at("num_ok"), 1);
  EXPECT_EQ(rx.at("mean_ms"), 132.33);
  EXPECT_TRUE(rx.at("sigma_ms").is_null());
  EXPECT_TRUE(rx.at("truth_mean_ms").is_null());
  const std::string notes = o.at("notes").dump();
  EXPECT_NE(notes.find("trial 1 of step 1: no image motion seen"), std::string::npos) << notes;
  EXPECT_NE(notes.find("1 trial(s) without truth: latency.csv lacks command_ns"), std::string::npos) << notes;
  fs::remove_all(old);
}

TEST(ReferenceChecks, AlignmentVerdictAgainstTheStatedTolerance) {
  sim::VirtualOwl owl({});
  const std::string dir = RunStandard(owl, "alignment", "alignment");
  const nlohmann::json a = Checks({{"alignment", dir}}, owl.Config(), std::nullopt).at("alignment");
  std::vector<double> dy, roll;
  for (const auto& r : protocols::ReadAlignmentCsv(dir)) {
    dy.push_back(*r.vertical_offset_px);
    roll.push_back(*r.roll_deg);
  }
  ASSERT_EQ(dy.size(), 3u);
  EXPECT_NEAR(a.at("vertical_offset_px").get<double>(), (dy[0] + dy[1] + dy[2]) / 3, 1e-9);
  EXPECT_NEAR(a.at("roll_deg").get<double>(), (roll[0] + roll[1] + roll[2]) / 3, 1e-9);
  EXPECT_TRUE(a.at("vertical_offset_sigma_px").is_number());
  EXPECT_EQ(a.at("tolerance_vertical_px"), 1.0);
  EXPECT_NEAR(a.at("tolerance_roll_deg").get<double>(), std::atan(1.0 / 320) * 180 / M_PI, 1e-12);
  EXPECT_NE(a.at("tolerance_source").get<std::string>().find("block matcher"), std::string::npos);
  // The default virtual Owl's tilt centres differ from the robot file's: the eyes are not aligned.
  EXPECT_GT(std::abs(a.at("vertical_offset_px").get<double>()), 1.0);
  EXPECT_EQ(a.at("verdict"), "outside tolerance");
  EXPECT_NE(a.at("advice").dump().find("us of one eye's tilt"), std::string::npos);

  // The verdict itself, on given frames.
  using evaluation::AlignmentFrame;
  auto check = [](const std::vector<AlignmentFrame>& f) { return evaluation::CheckAlignment(f, 640, 585, 0.113); };
  EXPECT_EQ(check({{"chessboard", 0.1, 0.8, 3.0}, {"chessboard", 0.12, 0.9, 3.0}}).verdict, "within tolerance");
  EXPECT_EQ(check({{"chessboard", 0.25, 0.2, 3.0}}).verdict, "outside tolerance");  // roll over 0.179 deg
  EXPECT_EQ(check({{"chessboard", 0.0, -1.2, 3.0}}).verdict, "outside tolerance");  // offset over 1 px
  const evaluation::AlignmentCheck pc = check({{"phase-correlation", std::nullopt, 0.5, 2.0}});
  EXPECT_EQ(pc.verdict, "within tolerance");
  EXPECT_EQ(pc.num_roll, 0);
  EXPECT_NE(pc.advice.at(0).find("roll not measured"), std::string::npos);
  // Chessboard frames are preferred over phase correlation.
  EXPECT_EQ(check({{"phase-correlation", std::nullopt, 5.0, 2.0}, {"chessboard", 0.0, 0.5, 2.0}}).vertical_px, 0.5);
  EXPECT_EQ(check({}).verdict, "not measured");
  // 15 px at f = 585 px and 0.113 deg/us: 13 us of tilt.
  EXPECT_NE(check({{"chessboard", 0.0, 15.0, 0.0}}).advice.at(0).find("about 13 us"), std::string::npos);
}

TEST(ReferenceChecks, TheReportTablesCarryTheNumbers) {
  // A global-shutter stream, so every latency reading lands on the predicted frame ("8 of 8").
  sim::VirtualOwlOptions vo;
  vo.truth = sim::DefaultRobotTruth();
  vo.truth->stream = sim::StreamTruth();
  sim::VirtualOwl owl(vo);
  const std::string lat = RunStandard(owl, "latency", "report_latency");
  const std::string al = RunStandard(owl, "alignment", "report_alignment");
  CalibratePipelineOptions o;
  o.config = owl.Config();
  o.latency_truth = TruthOf(owl.Truth());
  const evaluation::CalibrationRun run = CalibrateFromDatasets({{"latency", lat}, {"alignment", al}}, o);
  const nlohmann::json& rc = run.result.diagnostics.at("reference_checks");
  std::map<std::string, reports::Table> tables;
  for (const auto& t : reports::MakeTables(run)) tables[t.name] = t;
  ASSERT_TRUE(tables.count("latency_check"));
  ASSERT_TRUE(tables.count("alignment_check"));
  EXPECT_FALSE(tables.count("field_of_view"));  // no cameras fitted: no row made up
  const reports::Table& l = tables["latency_check"];
  ASSERT_EQ(l.rows.size(), 3u);  // Rx, Lx, all
  EXPECT_EQ(l.header[6], "truth [ms]");
  const nlohmann::json& all = Group(rc.at("latency"), "all");
  EXPECT_EQ(l.rows[2][0], "all");
  EXPECT_EQ(l.rows[2][2], reports::Fmt(all.at("mean_ms").get<double>(), 4));
  EXPECT_EQ(l.rows[2][3], reports::Fmt(all.at("sigma_ms").get<double>(), 2));
  EXPECT_EQ(l.rows[2][6], reports::Fmt(all.at("truth_mean_ms").get<double>(), 4));
  EXPECT_EQ(l.rows[2][8], "8 of 8");
  EXPECT_EQ(l.rows[2][10], "100");
  const reports::Table& a = tables["alignment_check"];
  EXPECT_NE(a.caption.find("outside tolerance"), std::string::npos);
  EXPECT_NE(a.caption.find("1 px of vertical disparity"), std::string::npos);
  EXPECT_EQ(a.rows[1][1], reports::Fmt(rc.at("alignment").at("vertical_offset_px").get<double>(), 3));
  EXPECT_EQ(a.rows[1][3], "\u00b11");
  EXPECT_EQ(a.rows[1][4], "no");
}

TEST(ReferenceChecks, FieldOfViewAgainstTheDatasheet) {
  const evaluation::PiCameraDatasheet ds;
  EXPECT_NEAR(ds.FocalPx(640), 634.92, 0.01);  // 3.6 mm / (1.4 um x 2592 / 640)
  EXPECT_NEAR(ds.FocalPx(1280), 2 * 634.92, 0.02);
  fitting::CalibrationResult r;
  models::CameraIntrinsics pin;
  pin.params = {634.92, 634.92, 319.5, 239.5, 0, 0, 0, 0, 0};
  models::CameraIntrinsics barrel = pin;
  barrel.params = {585, 584, 322, 236, -0.12, 0.09, 0, 0, -0.02};
  r.cameras[0] = pin;
  r.cameras[1] = barrel;
  for (const char* name : {"left.fx", "left.fy"}) {
    fitting::Parameter p;
    p.name = name;
    p.value = 634.92;
    p.sigma = 0.5;
    p.unit = "px";
    r.Set(p);
  }
  const evaluation::FovCheck c = evaluation::CheckFieldOfView(r, std::array<models::CameraIntrinsics, 2>{pin, pin});
  ASSERT_EQ(c.rows.size(), 2u);
  const evaluation::FovRow& l = c.rows[0];
  // A pinhole with the datasheet's focal length: 2 atan(320 / 634.92) = 53.50 deg (the notes: 53).
  EXPECT_NEAR(l.hfov_deg, 2 * std::atan(320 / 634.92) * 180 / M_PI, 1e-9);
  EXPECT_NEAR(l.hfov_deg, 53.50, 0.01);
  EXPECT_NEAR(l.vfov_deg, 41.41, 0.01);
  EXPECT_NEAR(l.pinhole_hfov_deg, l.hfov_deg, 1e-9);
  EXPECT_EQ(l.datasheet_hfov_deg, 53);
  EXPECT_EQ(l.datasheet_vfov_deg, 40);
  EXPECT_NEAR(l.datasheet_f_px, 634.92, 0.01);
  // sigma from fx's: d(2 atan(w / 2f)) / df = -w / (f^2 + w^2 / 4).
  EXPECT_NEAR(l.hfov_sigma_deg, 640 / (634.92 * 634.92 + 320 * 320) * 0.5 * 180 / M_PI, 1e-6);
  EXPECT_EQ(l.fx_sigma, 0.5);
  EXPECT_NEAR(*l.truth_hfov_deg, 53.50, 0.01);
  // Barrel distortion widens the field of view beyond the pinhole's of the same focal length.
  const evaluation::FovRow& b = c.rows[1];
  EXPECT_GT(b.hfov_deg, b.pinhole_hfov_deg + 0.5);
  EXPECT_NEAR(b.pinhole_hfov_deg, 2 * std::atan(320.0 / 585) * 180 / M_PI, 1e-9);
  EXPECT_TRUE(std::isnan(b.fx_sigma));  // no sigma given for the right eye: none reported
  EXPECT_TRUE(std::isnan(b.hfov_sigma_deg));
  const nlohmann::json j = evaluation::ToJson(c);
  EXPECT_NEAR(j.at("rows").at(0).at("f_minus_datasheet_px").get<double>(), 0.0, 0.01);
  EXPECT_NEAR(j.at("rows").at(1).at("f_minus_datasheet_px").get<double>(), 585 - 634.92, 0.01);
  EXPECT_NE(j.at("source").get<std::string>().find("3.6 mm"), std::string::npos);
}

}  // namespace reference_checks_test
}  // namespace owlcal::pipeline
