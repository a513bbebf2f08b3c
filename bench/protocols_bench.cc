// Prints how long each standard protocol takes on the in-process virtual Owl (wall clock on
// this machine and robot time), the frames it records and the dataset size: the budget of
// the main job (`owlcal calibrate` must finish in under 5 minutes on 2 cores).
#include <chrono>
#include <cstdio>
#include <filesystem>

#include "protocols/dataset.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "sim/virtual_owl.h"

int main() {
  namespace fs = std::filesystem;
  using namespace owlcal;
  double total_s = 0;
  std::printf("%-14s %8s %10s %8s %10s\n", "protocol", "wall_s", "robot_s", "frames", "MB");
  for (const std::string& name : protocols::StandardProtocolNames()) {
    sim::VirtualOwl owl(sim::VirtualOwlOptions{});
    const protocols::Protocol p = protocols::LoadProtocolFile(protocols::ResolveProtocolPath(name));
    protocols::RunOptions o;
    o.out_dir = (fs::temp_directory_path() / ("owlcal_bench_" + name)).string();
    fs::remove_all(o.out_dir);
    const auto t0 = std::chrono::steady_clock::now();
    const protocols::RunSummary s = protocols::RunProtocols({p}, owl, o);
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    uint64_t bytes = 0;
    for (const auto& e : fs::recursive_directory_iterator(o.out_dir))
      if (e.is_regular_file()) bytes += e.file_size();
    std::printf("%-14s %8.2f %10.1f %8lld %10.1f %s\n",
                name.c_str(),
                wall,
                s.elapsed_s,
                (long long)s.num_frames,
                bytes / 1e6,
                s.status == "complete" ? "" : s.status.c_str());
    total_s += wall;
    fs::remove_all(o.out_dir);
  }
  std::printf("standard suite total: %.1f s wall\n", total_s);
  return 0;
}
