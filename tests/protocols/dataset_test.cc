// Dataset crash safety: recordings killed (SIGKILL) at random moments always leave a dataset
// CheckDataset accepts, with every acknowledged frame intact.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "protocols/dataset.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "tests/protocols/fake_robot.h"

namespace owlcal::protocols {
namespace dataset_test {
namespace fs = std::filesystem;

std::string TempDir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("owlcal_dataset_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(p);
  return p.string();
}

TEST(Crc32, MatchesTheStandardCheckValue) {
  const std::string s = "123456789";
  EXPECT_EQ(Crc32(reinterpret_cast<const uint8_t*>(s.data()), s.size()), 0xCBF43926u);
}

TEST(Dataset, WritesReadsAndChecksFrames) {
  const std::string dir = TempDir("rw");
  {
    auto w = DatasetWriter::Create(dir, {{"note", "test"}});
    for (int i = 0; i < 5; ++i) {
      FrameRecord r;
      r.seq = 10 + i;
      r.stamp_ns = 1000 * i;
      r.pwm_us = {1500 + i, 1500, 1500, 1500, 1500};
      r.approach = {1, -1, 0, 0, 0};
      r.step_index = 2;
      r.step_name = "a,b \"c\"\nd";  // quoted in the file, read back exactly
      w->AppendFrame(std::vector<uint8_t>(100 + i, uint8_t(i)), r);
    }
    PlacementRecord p;
    p.target = "board";
    p.answer = " 600, I think ";
    p.distance_m = 0.6;
    p.base_from_target.translation() = Eigen::Vector3d(0.1, 0.2, 0.6);
    EXPECT_EQ(w->AppendPlacement(p), 0);
    w->Finish("complete", "");
  }
  const DatasetCheck c = CheckDataset(dir);
  EXPECT_TRUE(c.ok);
  EXPECT_EQ(c.num_frames, 5);
  EXPECT_EQ(c.status, "complete");
  const auto frames = ReadFramesCsv(dir);
  ASSERT_EQ(frames.size(), 5u);
  EXPECT_EQ(frames[3].pwm_us[0], 1503);
  EXPECT_EQ(frames[3].approach[1], -1);
  EXPECT_EQ(frames[3].step_name, "a,b \"c\"\nd");
  EXPECT_EQ(ReadFrameJpeg(dir, 4).size(), 104u);
  const auto placements = ReadPlacementsCsv(dir);
  ASSERT_EQ(placements.size(), 1u);
  EXPECT_NEAR(placements[0].base_from_target.translation().y(), 0.2, 1e-12);
  EXPECT_EQ(placements[0].answer, " 600, I think ");
  EXPECT_THROW(DatasetWriter::Create(dir, {}), std::runtime_error);  // never overwrites
}

TEST(Dataset, DetectsCorruptionAndMissingFrames) {
  const std::string dir = TempDir("corrupt");
  {
    auto w = DatasetWriter::Create(dir, {});
    for (int i = 0; i < 3; ++i) w->AppendFrame(std::vector<uint8_t>(50, uint8_t(i)), {});
  }
  {
    std::fstream f(FramePath(dir, 1), std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(10);
    f.put(char(99));
  }
  DatasetCheck c = CheckDataset(dir);
  EXPECT_FALSE(c.ok);
  ASSERT_FALSE(c.errors.empty());
  EXPECT_NE(c.errors[0].find("frames.csv:3"), std::string::npos) << c.errors[0];
  EXPECT_NE(c.errors[0].find("jpeg_crc32"), std::string::npos) << c.errors[0];
  fs::remove(FramePath(dir, 1));
  c = CheckDataset(dir);
  EXPECT_FALSE(c.ok);
  EXPECT_NE(c.errors[0].find("missing"), std::string::npos) << c.errors[0];
}

TEST(Dataset, PartialLastLineIsDroppedAndRepaired) {
  const std::string dir = TempDir("partial");
  {
    auto w = DatasetWriter::Create(dir, {});
    for (int i = 0; i < 4; ++i) w->AppendFrame(std::vector<uint8_t>(40, uint8_t(i)), {});
  }
  // Cut frames.csv in the middle of its last line.
  const auto size = fs::file_size(fs::path(dir) / "frames.csv");
  fs::resize_file(fs::path(dir) / "frames.csv", size - 7);
  DatasetCheck c = CheckDataset(dir);
  EXPECT_TRUE(c.ok);
  EXPECT_EQ(c.num_frames, 3);
  EXPECT_FALSE(c.warnings.empty());
  RepairDataset(dir);
  EXPECT_FALSE(fs::exists(FramePath(dir, 3)));
  c = CheckDataset(dir);
  EXPECT_TRUE(c.ok);
  EXPECT_EQ(c.num_frames, 3);
  // Resume continues the numbering.
  auto w = DatasetWriter::Resume(dir);
  EXPECT_EQ(w->AppendFrame(std::vector<uint8_t>(10, 1), {}), 3);
}

TEST(Dataset, ACutRecordIsDroppedEvenWhenItParses) {
  const std::string dir = TempDir("cutparses");
  {
    auto w = DatasetWriter::Create(dir, {});
    for (int i = 0; i < 3; ++i) w->AppendFrame(std::vector<uint8_t>(40, uint8_t(i)), {});
    w->Finish("complete", "");
  }
  // Cut off only the line break: the last record still has 18 cells, but the writer never
  // finished it (its CRC may be cut short), so it is not a frame.
  const fs::path csv = fs::path(dir) / "frames.csv";
  fs::resize_file(csv, fs::file_size(csv) - 1);
  DatasetCheck c = CheckDataset(dir);
  EXPECT_TRUE(c.ok);
  EXPECT_EQ(c.num_frames, 2);
  ASSERT_EQ(c.warnings.size(), 2u);  // the cut line, and frame 2's JPEG without its line
  EXPECT_NE(c.warnings[0].find("frames.csv: partial last line dropped"), std::string::npos) << c.warnings[0];
  EXPECT_NE(c.warnings[1].find("000002.jpg: frame without a frames.csv line dropped"), std::string::npos)
      << c.warnings[1];
  EXPECT_EQ(ReadFramesCsv(dir).size(), 2u);
  RepairDataset(dir);
  EXPECT_EQ(CheckDataset(dir).warnings.size(), 0u);
  EXPECT_EQ(ReadFramesCsv(dir).size(), 2u);
}

TEST(Dataset, ErrorsNameFileLineAndField) {
  const std::string dir = TempDir("badfield");
  {
    auto w = DatasetWriter::Create(dir, {});
    FrameRecord r;
    r.pwm_us = {1500, 1501, 1502, 1503, 1504};
    for (int i = 0; i < 2; ++i) w->AppendFrame(std::vector<uint8_t>(40, uint8_t(i)), r);
  }
  const fs::path csv = fs::path(dir) / "frames.csv";
  std::ifstream in(csv);
  std::string header, l1, l2;
  std::getline(in, header);
  std::getline(in, l1);
  std::getline(in, l2);
  in.close();
  l2.replace(l2.find(",1500,"), 6, ",nan,");  // Rx_us of frame 1
  std::ofstream(csv) << header << "\n" << l1 << "\n" << l2 << "\n";
  try {
    ReadFramesCsv(dir);
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), csv.string() + ":3 field Rx_us = 'nan' is not an integer");
  }
  const DatasetCheck c = CheckDataset(dir);
  EXPECT_FALSE(c.ok);
  ASSERT_EQ(c.errors.size(), 1u);
  EXPECT_NE(c.errors[0].find("frames.csv:3 field Rx_us"), std::string::npos) << c.errors[0];
}

// Rewrites manifest.json's num_frames as `value` (raw JSON text).
void SetManifestFrames(const std::string& dir, const std::string& value) {
  const fs::path manifest = fs::path(dir) / "manifest.json";
  std::ifstream in(manifest);
  nlohmann::json j = nlohmann::json::parse(in);
  in.close();
  j["num_frames"] = nlohmann::json::parse(value);
  std::ofstream(manifest) << j.dump(2) << "\n";
}

// Regression: a frames.csv with only its header passed as "ok: 0 frames, complete" although the
// manifest said 53 frames and the JPEGs were on disk, and a manifest claiming 99,999,999,999
// frames was not flagged.
TEST(Dataset, FramesCsvMustHoldTheFramesTheManifestCounts) {
  const std::string dir = TempDir("count");
  {
    auto w = DatasetWriter::Create(dir, {});
    for (int i = 0; i < 5; ++i) w->AppendFrame(std::vector<uint8_t>(40, uint8_t(i)), {});
    w->Finish("complete", "");
  }
  ASSERT_TRUE(CheckDataset(dir).ok);
  const fs::path csv = fs::path(dir) / "frames.csv";
  std::string header;
  {
    std::ifstream in(csv);
    std::getline(in, header);
  }
  std::ofstream(csv, std::ios::trunc) << header << "\n";
  DatasetCheck c = CheckDataset(dir);
  EXPECT_FALSE(c.ok);
  ASSERT_EQ(c.errors.size(), 1u);
  EXPECT_NE(c.errors[0].find("manifest.json field num_frames = 5 but frames.csv has 0 complete line(s)"),
            std::string::npos)
      << c.errors[0];
  SetManifestFrames(dir, "99999999999");
  c = CheckDataset(dir);
  EXPECT_FALSE(c.ok);
  ASSERT_EQ(c.errors.size(), 1u);
  EXPECT_NE(c.errors[0].find("num_frames = 99999999999 is not a frame count"), std::string::npos) << c.errors[0];
  SetManifestFrames(dir, "\"5\"");
  EXPECT_FALSE(CheckDataset(dir).ok);
  SetManifestFrames(dir, "0");  // consistent again: the orphan JPEGs are warnings
  c = CheckDataset(dir);
  EXPECT_TRUE(c.ok) << (c.errors.empty() ? "" : c.errors[0]);
  EXPECT_EQ(c.warnings.size(), 5u);
}

// Regression: nlohmann-json kept the last of two equal keys without a word.
TEST(Dataset, ManifestWithARepeatedKeyIsRefused) {
  const std::string dir = TempDir("dupkey");
  { auto w = DatasetWriter::Create(dir, {}); }
  const fs::path manifest = fs::path(dir) / "manifest.json";
  std::ifstream in(manifest);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  in.close();
  EXPECT_NO_THROW(ReadManifest(dir));
  const size_t brace = text.find('{');
  ASSERT_NE(brace, std::string::npos);
  text.insert(brace + 1, "\"status\": \"complete\",");
  std::ofstream(manifest) << text;
  try {
    ReadManifest(dir);
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), manifest.string() + ": key 'status' given twice") << e.what();
  }
}

// Forks a recording, SIGKILLs it at a random moment, checks the dataset. The child writes one
// byte per frame to a pipe AFTER the frame's line is flushed: every acknowledged frame must
// survive.
TEST(Dataset, KilledRecordingsAlwaysLeaveACheckableDataset) {
  const Protocol p = ParseProtocolYaml(R"(
name: kill
steps:
  - move-to: {pose: {Rx: centre+10}, settle: {mode: time, time_ms: 10}}
  - capture: {frames: 400, settle: {mode: time, time_ms: 1}}
)",
                                       "kill.yaml");
  std::mt19937 rng(20261122);
  int killed_with_frames = 0;
  for (int trial = 0; trial < 24; ++trial) {
    const std::string dir = TempDir("kill" + std::to_string(trial));
    int fds[2];
    ASSERT_EQ(::pipe(fds), 0);
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      ::close(fds[0]);
      testing::FakeRobot robot;
      RunOptions o;
      o.out_dir = dir;
      o.on_frame = [&](int64_t) {
        const char b = 1;
        if (::write(fds[1], &b, 1) != 1) ::_exit(3);
      };
      RunProtocols({p}, robot, o);
      ::_exit(0);
    }
    ::close(fds[1]);
    // Wait for a random number of acknowledged frames, then a random extra delay, then kill.
    const int wait_frames = std::uniform_int_distribution<int>(0, 60)(rng);
    int acked = 0;
    char buf[256];
    while (acked < wait_frames) {
      const ssize_t n = ::read(fds[0], buf, sizeof(buf));
      if (n <= 0) break;
      acked += int(n);
    }
    ::usleep(std::uniform_int_distribution<int>(0, 4000)(rng));
    ::kill(pid, SIGKILL);
    int status = 0;
    ::waitpid(pid, &status, 0);
    // Drain acknowledgements written before the kill.
    ssize_t n;
    while ((n = ::read(fds[0], buf, sizeof(buf))) > 0) acked += int(n);
    ::close(fds[0]);
    if (!fs::exists(fs::path(dir) / "manifest.json")) {
      EXPECT_EQ(acked, 0) << "trial " << trial;
      continue;
    }
    const DatasetCheck c = CheckDataset(dir);
    EXPECT_TRUE(c.ok) << "trial " << trial << ": " << (c.errors.empty() ? "" : c.errors[0]);
    EXPECT_GE(c.num_frames, acked) << "trial " << trial << ": an acknowledged frame was lost";
    EXPECT_LE(c.num_frames, acked + 1) << "trial " << trial;
    if (c.num_frames > 0) ++killed_with_frames;
    // A killed dataset can always be repaired and resumed.
    EXPECT_NO_THROW(RepairDataset(dir)) << "trial " << trial;
    EXPECT_TRUE(CheckDataset(dir).warnings.size() <= 1) << "trial " << trial;  // only "interrupted"
    fs::remove_all(dir);
  }
  EXPECT_GE(killed_with_frames, 20);
}

}  // namespace dataset_test
}  // namespace owlcal::protocols
