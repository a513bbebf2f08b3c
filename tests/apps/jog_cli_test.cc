// owlcal jog through a pseudo-terminal: a person's keys (raw mode, arrow escape sequences)
// drive the virtual Owl; the jog refuses to pass the file's limit without the explicit key,
// widens the neck's max until the images show the end-stop, widens its min by one step that the
// person confirms, narrows Rx's max to where the socket rim goes (it shows already at the file's
// limit on the default virtual Owl), writes the robot file and the Pi server's constants (Python and C forms),
// and re-validates the new file with the limits protocol. The written files parse and stay
// within the confirmed stops (the virtual Owl's true end-stops). Then the prompt fallback with
// stdin not a terminal, whose re-validation fails a servo the person left in the socket rim.
#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "calib/csv.h"
#include "robot/robot_file.h"
#include "sim/robot_truth.h"

namespace owlcal {
namespace {
namespace fs = std::filesystem;

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Reads from fd into *out until `until` appears (returns true) or the child closes the pty
// or the timeout passes (false).
bool ReadUntil(int fd, std::string* out, const std::string& until, int timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(timeout_s);
  while (std::chrono::steady_clock::now() < deadline) {
    if (!until.empty() && out->find(until) != std::string::npos) return true;
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 200) <= 0) continue;
    char buf[4096];
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n <= 0) return !until.empty() && out->find(until) != std::string::npos;  // EIO: child closed
    out->append(buf, size_t(n));
  }
  return false;
}

// Limits per name from the Python form: "if (Rx>1905):\n    Rx = 1905".
std::map<std::string, int> PythonBounds(const std::string& text, char op) {
  std::map<std::string, int> m;
  const std::regex re(std::string("if \\((\\w+)\\") + op + "(\\d+)\\):\\n    (\\w+) = (\\d+)");
  for (auto it = std::sregex_iterator(text.begin(), text.end(), re); it != std::sregex_iterator(); ++it) {
    EXPECT_EQ((*it)[1], (*it)[3]);
    EXPECT_EQ((*it)[2], (*it)[4]);
    m[(*it)[1]] = std::stoi((*it)[2]);
  }
  return m;
}

// "int RxR = 1905;" and "int RxC=1545;" from the C form.
std::map<std::string, int> CInts(const std::string& text) {
  std::map<std::string, int> m;
  const std::regex re("int (\\w+) ?= ?(\\d+);");
  for (auto it = std::sregex_iterator(text.begin(), text.end(), re); it != std::sregex_iterator(); ++it)
    m[(*it)[1]] = std::stoi((*it)[2]);
  return m;
}

TEST(OwlcalJog, KeysThroughAPtyWidenConfirmWriteAndRevalidate) {
  const std::string out = (fs::temp_directory_path() / ("owlcal_jog_pty_" + std::to_string(::getpid()))).string();
  fs::remove_all(out);
  int master = -1;
  const pid_t pid = ::forkpty(&master, nullptr, nullptr, nullptr);
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    ::execl(OWLCAL_BINARY,
            OWLCAL_BINARY,
            "jog",
            "--robot",
            "sim",
            "--out",
            out.c_str(),
            "--revalidate-servos",
            "Neck",
            "Rx",
            static_cast<char*>(nullptr));
    std::_Exit(127);
  }
  std::string log;
  ASSERT_TRUE(ReadUntil(master, &log, "raw keys ready", 120)) << log;
  auto send = [&](const std::string& keys, const std::string& wait_for) {
    ASSERT_EQ(::write(master, keys.data(), keys.size()), ssize_t(keys.size()));
    const size_t from = log.size();
    ASSERT_TRUE(ReadUntil(master, &log, wait_for, 120)) << "after '" << keys << "':\n" << log.substr(from);
  };
  send("5", "selected Neck");
  send("]", "Neck -> its max limit 1950 us");
  send("\x1b[C", "is at its max limit 1950 us (file): not moved");  // right arrow: refused
  send("a", "servo back there");  // widened until the image stops following (the end-stop)
  send("[", "Neck -> its min limit 1100 us");
  send("\x1b[D", "is at its min limit 1100 us (file): not moved");  // left arrow: refused
  send("w", "Neck min widened to 1095 us");
  send("\r", "Neck min limit confirmed at 1095 us");
  send("1", "selected Rx");
  send("]", "Rx -> its max limit 1890 us");
  send("a", "servo there");  // the socket rim already shows at 1890: narrowed to where it goes
  send("[", "Rx -> its min limit 1200 us");
  send("a", "servo there");         // and at 1200
  send("s", "/revalidation.csv)");  // the final line (either outcome)
  std::string rest;
  ReadUntil(master, &rest, "", 30);
  log += rest;
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ::close(master);
  ASSERT_TRUE(WIFEXITED(status)) << log;
  // Keys were not echoed (raw mode) and the position was shown after each key.
  EXPECT_EQ(log.find("\x1b[C"), std::string::npos);
  EXPECT_NE(log.find("Neck 1950 us  [min 1100 file .. max 1950 file]"), std::string::npos) << log;

  // Nothing beyond the file's limit before the explicit key: the position after the refused
  // arrow is still 1950 (the status line printed after it).
  const size_t refused = log.find("not moved");
  ASSERT_NE(refused, std::string::npos);
  EXPECT_NE(log.find("Neck 1950 us", refused), std::string::npos);

  // The written robot file loads; its limits are the confirmed stops and lie within the virtual
  // Owl's true end-stops.
  const sim::RobotTruth truth = sim::DefaultRobotTruth();
  const models::RobotConfig& file = truth.robot;  // the virtual Owl's server file (the guide's limits)
  const models::RobotConfig got = robot::LoadRobotFile(out + "/robot.yaml");
  const int neck_max = got.servos[models::kNeck].max_us;
  // The stop (1960 us at the middle of the backlash band) is met at +half the band when it is
  // approached from below, as a widening does.
  const double neck_stop = truth.servos[models::kNeck].endstop_hi_us + truth.servos[models::kNeck].hysteresis_us / 2;
  EXPECT_GT(neck_max, 1950);                          // widened
  EXPECT_LE(neck_max, neck_stop);                     // within the true stop
  EXPECT_GE(neck_max, neck_stop - 8);                 // and found near it
  EXPECT_EQ(got.servos[models::kNeck].min_us, 1095);  // confirmed
  EXPECT_GE(got.servos[models::kNeck].min_us, truth.servos[models::kNeck].endstop_lo_us);
  const int rx_max = got.servos[models::kRx].max_us;
  EXPECT_LT(rx_max, 1890);  // narrowed to the rim
  EXPECT_GT(rx_max, file.servos[models::kRx].centre_us + 150);
  for (int s : {models::kRy, models::kLx, models::kLy}) {
    EXPECT_EQ(got.servos[s].min_us, file.servos[s].min_us) << models::kServoNames[s];
    EXPECT_EQ(got.servos[s].max_us, file.servos[s].max_us) << models::kServoNames[s];
  }
  const int rx_min = got.servos[models::kRx].min_us;
  EXPECT_GT(rx_min, 1200);
  EXPECT_LT(rx_min, file.servos[models::kRx].centre_us - 150);
  // jog.csv says how each end was set.
  const calib::CsvTable jog = calib::CsvTable::Read(out + "/jog.csv");
  ASSERT_EQ(jog.NumRows(), 10u);
  EXPECT_EQ(jog.Text(1, "servo"), "Rx");
  EXPECT_EQ(jog.Text(0, "how"), "rim");
  EXPECT_EQ(jog.Text(1, "how"), "rim");
  EXPECT_EQ(jog.Text(8, "servo"), "Neck");
  EXPECT_EQ(jog.Text(8, "how"), "confirmed");
  EXPECT_EQ(jog.Text(9, "how"), "end-stop");
  EXPECT_EQ(jog.Int(9, "in_file", 1000, 9999), neck_max);

  // The server constants parse and agree with the robot file, in both forms.
  const std::map<std::string, int> hi = PythonBounds(ReadText(out + "/server_limits.py"), '>');
  const std::map<std::string, int> lo = PythonBounds(ReadText(out + "/server_limits.py"), '<');
  ASSERT_EQ(hi.size(), 5u);
  ASSERT_EQ(lo.size(), 5u);
  for (int s = 0; s < models::kNumServos; ++s) {
    EXPECT_EQ(hi.at(models::kServoNames[s]), got.servos[s].max_us) << models::kServoNames[s];
    EXPECT_EQ(lo.at(models::kServoNames[s]), got.servos[s].min_us) << models::kServoNames[s];
  }
  const std::map<std::string, int> c = CInts(ReadText(out + "/server_limits.h"));
  EXPECT_EQ(c.at("RxR"), rx_max);  // Rx: increasing PWM turns right
  EXPECT_EQ(c.at("RxL"), rx_min);
  EXPECT_EQ(c.at("LyB"), got.servos[models::kLy].max_us);  // mirrored: the max is the bottom
  EXPECT_EQ(c.at("LyT"), got.servos[models::kLy].min_us);
  EXPECT_EQ(c.at("NeckR"), 1095);  // the neck turns left with increasing PWM
  EXPECT_EQ(c.at("NeckL"), neck_max);
  EXPECT_EQ(c.at("RyC"), got.servos[models::kRy].centre_us);

  // The re-validation ran the limits protocol on the new file: both servos pass.
  const calib::CsvTable rv = calib::CsvTable::Read(out + "/revalidation.csv");
  ASSERT_EQ(rv.NumRows(), 2u);
  for (size_t r = 0; r < 2; ++r)
    EXPECT_EQ(rv.Text(r, "result"), "pass") << rv.Text(r, "servo") << ": " << rv.Text(r, "message") << "\n" << log;
  EXPECT_EQ(rv.Text(0, "servo"), "Neck");
  EXPECT_EQ(rv.Int(0, "max_us", 1000, 9999), neck_max);
  EXPECT_TRUE(fs::exists(out + "/revalidation/limits.csv"));
  EXPECT_EQ(WEXITSTATUS(status), 0) << log;
  fs::remove_all(out);
}

TEST(OwlcalJog, PromptFallbackWhenStdinIsNotATerminal) {
  const std::string out = (fs::temp_directory_path() / ("owlcal_jog_prompt_" + std::to_string(::getpid()))).string();
  fs::remove_all(out);
  const std::string cmd = std::string(OWLCAL_BINARY) + " jog --robot sim --revalidate-servos Ly --out " + out +
                          " 2>&1 <<'EOF'\n4\n[\n+ + c\ns\nEOF";
  FILE* p = ::popen(cmd.c_str(), "r");
  ASSERT_NE(p, nullptr);
  std::string log;
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) log.append(buf, n);
  const int status = ::pclose(p);
  // Ly's max (2000 us, the file's) lies in the socket rim of the virtual Owl: the re-validation
  // fails Ly, and the exit code says so.
  ASSERT_EQ(WEXITSTATUS(status), 3) << log;
  EXPECT_NE(log.find("prompt mode"), std::string::npos) << log;
  EXPECT_NE(log.find("jog> "), std::string::npos);
  EXPECT_NE(log.find("Ly -> its min limit 1180 us"), std::string::npos) << log;
  EXPECT_NE(log.find("Ly min limit confirmed at 1190 us"), std::string::npos) << log;
  const models::RobotConfig got = robot::LoadRobotFile(out + "/robot.yaml");
  EXPECT_EQ(got.servos[models::kLy].min_us, 1190);  // narrowed by the person
  EXPECT_EQ(got.servos[models::kLy].max_us, 2000);
  const std::map<std::string, int> c = CInts(ReadText(out + "/server_limits.h"));
  EXPECT_EQ(c.at("LyT"), 1190);
  const calib::CsvTable rv = calib::CsvTable::Read(out + "/revalidation.csv");
  ASSERT_EQ(rv.NumRows(), 1u);
  EXPECT_EQ(rv.Text(0, "servo"), "Ly");
  EXPECT_EQ(rv.Text(0, "result"), "fail");
  EXPECT_EQ(rv.Text(0, "cause_max"), "rim");
  EXPECT_NE(log.find("Ly: FAIL"), std::string::npos) << log;
  fs::remove_all(out);
}

}  // namespace
}  // namespace owlcal
