// Virtual Owl rendering speed on one core: stereo frames per second for
//   1. the renderer alone (two 640x480 eyes, no noise, no JPEG),
//   2. render + sensor noise + side-by-side composition (encode_jpeg = false),
//   3. the full stream path: + JPEG encode (quality from the truth) + decode into halves.
// Prints wall-clock and thread-CPU rates (the CPU figure is robust on a loaded machine).
// Target: >= 60 stereo frames/s so the main job is never render-bound.
#include <time.h>

#include <chrono>
#include <cstdio>
#include <functional>

#include "sim/virtual_owl.h"

namespace {

double ThreadCpuSeconds() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec + ts.tv_nsec * 1e-9;
}

void Measure(const char* what, int n, const std::function<void(int)>& f) {
  f(0);  // warm up
  const auto w0 = std::chrono::steady_clock::now();
  const double c0 = ThreadCpuSeconds();
  for (int i = 1; i <= n; ++i) f(i);
  const double cpu = ThreadCpuSeconds() - c0;
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
  std::printf("%-44s %7.1f stereo frames/s (CPU)  %7.1f /s (wall)  %6.2f ms CPU per frame\n",
              what,
              n / cpu,
              n / wall,
              1e3 * cpu / n);
}

}  // namespace

int main() {
  using namespace owlcal;
  sim::VirtualOwlOptions raw;
  raw.encode_jpeg = false;
  sim::VirtualOwl owl_raw(raw);
  sim::VirtualOwl owl_jpeg(sim::VirtualOwlOptions{});
  // Eyes converged slightly on the chessboard so a target covers part of both images.
  robot::PwmVector cmd = owl_raw.Config().Centre();
  cmd[models::kRx] -= 20;
  cmd[models::kLx] += 20;
  owl_raw.SendServos(cmd);
  owl_jpeg.SendServos(cmd);
  owl_raw.SleepNs(1'000'000'000);
  owl_jpeg.SleepNs(1'000'000'000);
  const models::JointAngles a = owl_raw.JointAnglesAt(owl_raw.NowNs());
  const int n = 60;
  std::printf("virtual Owl render benchmark: %d frames each, 1280x480 side by side, %zu targets + wall\n",
              n,
              owl_raw.SceneState().targets.size());
  Measure("renderer only (2 eyes, no noise)", n, [&](int) {
    owl_raw.RenderEyeGrey(models::kLeftEye, a);
    owl_raw.RenderEyeGrey(models::kRightEye, a);
  });
  Measure("render + noise + compose (no JPEG)", n, [&](int i) { owl_raw.RenderFrame(30 + i); });
  Measure("full stream frame (+ JPEG encode + decode)", n, [&](int i) { owl_jpeg.RenderFrame(30 + i); });
  int64_t after = owl_jpeg.NowNs();
  const double c0 = ThreadCpuSeconds();
  int grabbed = 0;
  for (int i = 0; i < n; ++i) {
    auto f = owl_jpeg.GrabFrame(after, 1'000'000'000);
    if (!f) break;
    after = f->stamp_ns;
    ++grabbed;
  }
  const double cpu = ThreadCpuSeconds() - c0;
  std::printf("GrabFrame loop: %d frames = %.2f s of virtual time in %.2f s CPU (%.1fx real time)\n",
              grabbed,
              grabbed / owl_jpeg.Truth().stream.fps,
              cpu,
              grabbed / owl_jpeg.Truth().stream.fps / cpu);
  return 0;
}
