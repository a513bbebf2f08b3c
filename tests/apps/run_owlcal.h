#pragma once
// Runs the built `owlcal` binary as a user would (popen; exit code and stdout+stderr), for the
// command-line tests. The binary's path comes from OWLCAL_BINARY (tests/CMakeLists.txt); a test
// fixture skips when it is empty.
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <string>

namespace owlcal::test_cli {

inline std::string OwlcalBinary() {
#ifdef OWLCAL_BINARY
  if (std::filesystem::exists(OWLCAL_BINARY)) return OWLCAL_BINARY;
#endif
  return "";
}

struct RunResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

inline RunResult RunOwlcal(const std::string& args) {
  RunResult r;
  std::string cmd = OwlcalBinary();  // appended in place: GCC 12 warns (-Wrestrict) on a literal + string
  cmd.insert(cmd.begin(), '\'');
  cmd.append("' ").append(args).append(" 2>&1");
  FILE* pipe = popen(cmd.c_str(), "r");
  if (!pipe) return r;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof(buf), pipe)) > 0) r.output.append(buf, n);
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

}  // namespace owlcal::test_cli
