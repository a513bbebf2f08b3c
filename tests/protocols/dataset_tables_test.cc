// The measurement tables as a contract: what DatasetWriter::AppendRow writes, the typed readers
// read back exactly (free text with commas, quotes and line breaks too); bad cells are errors
// naming path:line and column; older datasets without the status columns still read.
#include "protocols/dataset_tables.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>

#include <gtest/gtest.h>

#include "protocols/dataset.h"

namespace owlcal::protocols {
namespace {
namespace fs = std::filesystem;

std::string TempDir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("owlcal_tables_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(p);
  fs::create_directories(p);
  return p.string();
}

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "(no error)";
}

void Write(const std::string& path, const std::string& text) { std::ofstream(path, std::ios::binary) << text; }

// The header the runner writes (protocols/runner.h).
constexpr const char* kFixationsHeader =
    "step_index,step_name,placement_index,target,distance_m,eyes,gain,outcome,iterations,Rx_us,Ry_us,"
    "Lx_us,Ly_us,Neck_us,left_found,left_dx_px,left_dy_px,right_found,right_dx_px,right_dy_px,stamp_ns,"
    "approach_Rx,approach_Ry,approach_Lx,approach_Ly,approach_Neck,status,reason";

TEST(DatasetTables, FixationsWrittenByTheWriterReadBackExactly) {
  const std::string dir = TempDir("fix");
  {
    auto w = DatasetWriter::Create(dir, {});
    w->AppendRow("fixations.csv", kFixationsHeader, {"2",      "near, left", "0",         "disc",  "0.600000", "both",
                                                     "0.3000", "converged",  "17",        "1480",  "1510",     "1620",
                                                     "1505",   "1530",       "1",         "0.250", "-0.125",   "1",
                                                     "-0.500", "0.750",      "123456789", "1",     "-1",       "0",
                                                     "1",      "0",          "ok",        ""});
    w->AppendRow("fixations.csv",
                 kFixationsHeader,
                 {"2",         "far",  "1",           "disc",
                  "",          "both", "0.3000",      "target-lost",
                  "40",        "1480", "1510",        "1620",
                  "1505",      "1530", "1",           "0.000",
                  "0.000",     "0",    "nan",         "nan",
                  "223456789", "0",    "0",           "0",
                  "0",         "0",    "lost target", "right eye: \"disc\" left the image,\nafter 12 frames"});
  }
  const std::vector<FixationRow> rows = ReadFixationsCsv(dir);
  ASSERT_EQ(rows.size(), 2u);
  const FixationRow& a = rows[0];
  EXPECT_EQ(a.line, 2);
  EXPECT_EQ(a.step_name, "near, left");
  EXPECT_EQ(a.distance_m, 0.6);
  EXPECT_EQ(a.gain, 0.3);
  EXPECT_EQ(a.iterations, 17);
  EXPECT_EQ(a.pwm_us, (models::PwmVector{1480, 1510, 1620, 1505, 1530}));
  ASSERT_TRUE(a.offset_px[0] && a.offset_px[1]);
  EXPECT_EQ(*a.offset_px[0], Eigen::Vector2d(0.25, -0.125));
  EXPECT_EQ(*a.offset_px[1], Eigen::Vector2d(-0.5, 0.75));
  EXPECT_EQ(a.stamp_ns, 123456789);
  EXPECT_EQ(a.approach[models::kRy], -1);
  EXPECT_EQ(a.approach[models::kLy], 1);
  EXPECT_EQ(a.status, calib::TrialStatus::kOk);
  const FixationRow& b = rows[1];
  EXPECT_EQ(b.line, 3);
  EXPECT_FALSE(b.distance_m);  // no placement: empty cell
  EXPECT_FALSE(b.found[1]);
  EXPECT_FALSE(b.offset_px[1]);  // "nan" as earlier runners wrote it: not measured
  EXPECT_EQ(b.status, calib::TrialStatus::kLostTarget);
  EXPECT_EQ(b.reason, "right eye: \"disc\" left the image,\nafter 12 frames");
}

TEST(DatasetTables, BadCellsAreErrorsNamingPathLineAndColumn) {
  const std::string dir = TempDir("bad");
  const std::string latency = dir + "/latency.csv";
  const std::string header = "step_index,trial,servo,amplitude_us,latency_ms,frames_waited,shift_px\n";
  Write(latency, header + "0,0,Rx,40,120.5,5,3.2\n0,1,Rx,40,12O,5,3.2\n");
  EXPECT_EQ(ErrorOf([&] { ReadLatencyCsv(dir); }),
            latency + ":3: column latency_ms = '12O' is not a finite decimal number");
  Write(latency, header + "0,0,Rx,40,inf,5,3.2\n");
  EXPECT_EQ(ErrorOf([&] { ReadLatencyCsv(dir); }),
            latency + ":2: column latency_ms = 'inf' is not a finite decimal number");
  Write(latency, header + "0,0,Rx,40,-3,5,3.2\n");
  EXPECT_NE(ErrorOf([&] { ReadLatencyCsv(dir); }).find(latency + ":2: column latency_ms = -3 is outside"),
            std::string::npos);
  Write(latency, "step_index,trial,servo,amplitude_us,frames_waited,shift_px\n0,0,Rx,40,5,3.2\n");
  EXPECT_NE(ErrorOf([&] { ReadLatencyCsv(dir); }).find(latency + ":1: missing column 'latency_ms'"), std::string::npos);
  Write(latency, header + "0,0,Rx,40,120.5,5\n");
  EXPECT_EQ(ErrorOf([&] { ReadLatencyCsv(dir); }), latency + ":2: 6 cells, the header has 7");

  const std::string limits = dir + "/limits.csv";
  Write(limits,
        "step_index,servo,end,configured_us,measured_us,reason,last_shift_px,rim_darkening,status,message\n"
        "1,Rx,max,1900,1870,end-stop,0.100,0.0000,fine,\n");
  EXPECT_EQ(ErrorOf([&] { ReadLimitsCsv(dir); }),
            limits +
                ":2: column status = 'fine' is not a trial status (ok, not settled, lost target, off target, "
                "timed out, skipped, failed)");
}

TEST(DatasetTables, OlderDatasetsWithoutStatusColumnsStillRead) {
  const std::string dir = TempDir("old");
  Write(
      dir + "/step_trials.csv",
      "step_index,gain,amplitude_deg,trial,eye,axis,servo,start_pwm_us,fixation_pwm_us,outcome,frames,final_offset_px\n"
      "3,0.1000,5.000,0,left,pan,Lx,1600,1556,converged,40,0.412\n"
      "3,0.1000,5.000,1,left,pan,Lx,1512,1556,max-iterations,40,nan\n");
  const std::vector<StepTrialRow> t = ReadStepTrialsCsv(dir);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_FALSE(t[0].status);
  EXPECT_EQ(t[0].final_offset_px, 0.412);
  EXPECT_EQ(t[1].outcome, "max-iterations");
  EXPECT_FALSE(t[1].final_offset_px);
  Write(dir + "/limits.csv", "step_index,servo,end,configured_us,measured_us,reason\n1,Neck,min,1100,1150,end-stop\n");
  const std::vector<LimitRow> l = ReadLimitsCsv(dir);
  ASSERT_EQ(l.size(), 1u);
  EXPECT_EQ(l[0].measured_us, 1150);
  EXPECT_FALSE(l[0].status);
  EXPECT_FALSE(l[0].last_shift_px);
  EXPECT_FALSE(l[0].backlash_us);
  EXPECT_EQ(l[0].cause, "end-stop");
  // The backlash band column: a number, or empty when not measured.
  Write(dir + "/limits.csv",
        "step_index,servo,end,configured_us,measured_us,reason,backlash_us,status,message\n"
        "1,Neck,min,1100,1150,end-stop,11.25,ok,\n1,Neck,max,1950,1950,configured,,ok,\n");
  const std::vector<LimitRow> b = ReadLimitsCsv(dir);
  ASSERT_EQ(b.size(), 2u);
  EXPECT_EQ(b[0].backlash_us, 11.25);
  EXPECT_FALSE(b[1].backlash_us);
  Write(dir + "/limits.csv",
        "step_index,servo,end,configured_us,measured_us,reason,backlash_us\n1,Neck,min,1100,1150,end-stop,wide\n");
  EXPECT_NE(ErrorOf([&] { ReadLimitsCsv(dir); }).find("limits.csv:2: column backlash_us = 'wide'"), std::string::npos)
      << ErrorOf([&] { ReadLimitsCsv(dir); });
}

TEST(DatasetTables, MissingTablesHaveNoRowsAndACutTailIsDropped) {
  const std::string dir = TempDir("cut");
  EXPECT_TRUE(ReadFixationsCsv(dir).empty());
  EXPECT_TRUE(ReadStepResponseCsv(dir).empty());
  EXPECT_TRUE(ReadLatencyCsv(dir).empty());
  // A run killed while writing the last row: that row is not a measurement, even if it parses.
  Write(dir + "/step_response.csv",
        "step_index,gain,amplitude_deg,trial,k,t_s,offset_px,offset_y_px,pwm_us,found,frame_index\n"
        "3,0.2000,10.000,0,0,0.000000,86.100,0.200,1600,1,41\n"
        "3,0.2000,10.000,0,1,0.033333,70.000,0.100,1590,1,4");
  const std::vector<StepResponseRow> r = ReadStepResponseCsv(dir);
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].offset_px, 86.1);
  EXPECT_EQ(r[0].frame_index, 41);
  EXPECT_TRUE(r[0].found);
}

}  // namespace
}  // namespace owlcal::protocols
