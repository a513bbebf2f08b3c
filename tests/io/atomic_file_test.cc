// The one checked, atomic writer: a failed write (a full disk, a file-size limit) is an error naming
// the file, and the final name then holds the previous file or nothing, never a part of the new one.
#include "io/atomic_file.h"

#include <sys/resource.h>

#include <algorithm>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace owlcal::io {
namespace {

namespace fs = std::filesystem;

std::string Slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

fs::path FreshDir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("owlcal_atomic_file_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

// The files in `dir`, by name.
std::vector<std::string> Names(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

// Limits the size of any file this process writes to `bytes` while in scope: a write past it fails
// with EFBIG (SIGXFSZ ignored), as a nearly full disk fails with ENOSPC.
class FileSizeLimit {
 public:
  explicit FileSizeLimit(rlim_t bytes) {
    old_handler_ = std::signal(SIGXFSZ, SIG_IGN);
    getrlimit(RLIMIT_FSIZE, &old_);
    rlimit lim = old_;
    lim.rlim_cur = bytes;
    setrlimit(RLIMIT_FSIZE, &lim);
  }
  ~FileSizeLimit() {
    setrlimit(RLIMIT_FSIZE, &old_);
    std::signal(SIGXFSZ, old_handler_);
  }

 private:
  rlimit old_{};
  void (*old_handler_)(int) = nullptr;
};

TEST(AtomicFile, WritesTheWholeTextAndLeavesNoTemporary) {
  const fs::path d = FreshDir("whole");
  const std::string text(100000, 'x');
  WriteFileAtomic((d / "a.csv").string(), text);
  EXPECT_EQ(Slurp(d / "a.csv"), text);
  WriteFileAtomic((d / "a.csv").string(), "short\n");
  EXPECT_EQ(Slurp(d / "a.csv"), "short\n");
  EXPECT_EQ(Names(d), std::vector<std::string>{"a.csv"});
}

TEST(AtomicFile, AWriteToDevFullIsAnErrorNamingTheFile) {
  ASSERT_TRUE(fs::exists("/dev/full"));
  try {
    WriteFileAtomic("/dev/full", "u,v\n1,2\n");
    FAIL() << "a write to /dev/full succeeded";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/dev/full"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(std::strerror(ENOSPC)), std::string::npos) << e.what();
  }
  EXPECT_TRUE(fs::is_character_file("/dev/full"));  // written in place, never replaced by a rename
}

TEST(AtomicFile, AFailedWriteLeavesNoFileUnderItsFinalName) {
  const fs::path d = FreshDir("fresh");
  const std::string path = (d / "corners.csv").string();
  {
    const FileSizeLimit limit(4096);
    EXPECT_THROW(WriteFileAtomic(path, std::string(100000, 'x')), std::runtime_error);
  }
  EXPECT_FALSE(fs::exists(path));
  EXPECT_TRUE(Names(d).empty());  // no temporary left either
}

TEST(AtomicFile, AFailedWriteKeepsThePreviousFile) {
  const fs::path d = FreshDir("previous");
  const std::string path = (d / "corners.csv").string();
  WriteFileAtomic(path, "old\n");
  try {
    const FileSizeLimit limit(4096);
    WriteFileAtomic(path, std::string(100000, 'x'));
    FAIL() << "a write past the file-size limit succeeded";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  EXPECT_EQ(Slurp(path), "old\n");
  EXPECT_EQ(Names(d), std::vector<std::string>{"corners.csv"});
}

TEST(AtomicFile, AMissingFolderIsAnErrorNamingTheFile) {
  const std::string path = (FreshDir("missing") / "no" / "such" / "x.csv").string();
  try {
    WriteFileAtomic(path, "x\n");
    FAIL() << "a write into a missing folder succeeded";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

TEST(AtomicFile, KnowsItsTemporaries) {
  EXPECT_TRUE(IsAtomicTemporary("000001.jpg.tmp-4242"));
  EXPECT_TRUE(IsAtomicTemporary("manifest.json.tmp"));
  EXPECT_FALSE(IsAtomicTemporary("000001.jpg"));
  EXPECT_FALSE(IsAtomicTemporary("a.tmp-x"));
  EXPECT_FALSE(IsAtomicTemporary("a.tmp-"));
  EXPECT_FALSE(IsAtomicTemporary(".tmp"));
}

}  // namespace
}  // namespace owlcal::io
