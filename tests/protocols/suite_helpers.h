#pragma once
// Shared helpers of the standard-suite tests: run a standard protocol on the in-process
// virtual Owl and check the dataset it leaves.
#include <filesystem>
#include <sstream>

#include <gtest/gtest.h>

#include "calib/csv.h"
#include "owlcal_version.h"
#include "protocols/dataset.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "sim/robot_truth.h"
#include "sim/virtual_owl.h"

namespace owlcal::protocols::testing {

inline std::string TempDir(const std::string& name) {
  const std::filesystem::path p =
      std::filesystem::temp_directory_path() / ("owlcal_protocols_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(p);
  return p.string();
}

// The rows (cells by position) of a dataset table, read as every downstream reader does.
inline std::vector<std::vector<std::string>> ReadTableRows(const std::string& path) {
  const calib::CsvTable t = ReadAppendedCsv(path);
  std::vector<std::vector<std::string>> rows;
  for (size_t r = 0; r < t.NumRows(); ++r) rows.push_back(t.Cells(r));
  return rows;
}

struct Ran {
  RunSummary summary;
  std::string dir;
};

// truth_file: a robot-truth file relative to the source tree ("" = the default robot).
inline Ran RunStandard(const std::string& name, uint64_t seed = 1, const std::string& truth_file = "") {
  sim::VirtualOwlOptions vo;
  vo.seed = seed;
  if (!truth_file.empty()) vo.truth = sim::LoadRobotTruth(std::string(OWLCAL_SOURCE_DIR) + "/" + truth_file);
  sim::VirtualOwl owl(vo);
  std::vector<Protocol> p = {LoadProtocolFile(ResolveProtocolPath(name))};
  RunOptions o;
  o.out_dir = TempDir(name);
  o.robot_spec = "sim";
  o.sim = {{"seed", seed}};
  std::ostringstream progress;
  o.progress = &progress;
  Ran r;
  r.summary = RunProtocols(p, owl, o);
  r.dir = o.out_dir;
  std::cout << progress.str().substr(progress.str().size() > 3000 ? progress.str().size() - 3000 : 0);
  return r;
}

inline void ExpectCleanDataset(const Ran& r) {
  EXPECT_EQ(r.summary.status, "complete") << r.summary.message;
  EXPECT_EQ(r.summary.steps_done, r.summary.num_steps);
  const DatasetCheck c = CheckDataset(r.dir);
  EXPECT_TRUE(c.ok);
  for (const auto& e : c.errors) ADD_FAILURE() << e;
  EXPECT_EQ(c.num_frames, r.summary.num_frames);
  EXPECT_EQ(c.status, "complete");
  EXPECT_EQ(r.summary.num_clamped, 0);
}

}  // namespace owlcal::protocols::testing
