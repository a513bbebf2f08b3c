#include "pipeline/calibrate.h"

#include <algorithm>
#include <filesystem>
#include <future>
#include <memory>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include "pipeline/calibrate_work.h"
#include "pipeline/saccade_study.h"
#include "protocols/dataset.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "robot/reconfigured_robot.h"
#include "robot/robot_file.h"
#include "sim/virtual_owl.h"

namespace owlcal::pipeline {
namespace {

namespace fs = std::filesystem;

// Records one protocol into `dir`; its summary goes into *runs and a run that did not complete
// into *warnings. A user's stop throws.
void Record(const protocols::Protocol& p,
            const std::string& dir,
            const std::optional<protocols::CalibratedMaps>& calibration,
            robot::RobotInterface& robot,
            const CalibrateOptions& o,
            nlohmann::json* runs,
            std::vector<std::string>* warnings) {
  if (o.progress) o.progress("protocol " + p.name + " -> " + dir);
  protocols::RunOptions ro;
  ro.out_dir = dir;
  ro.robot_spec = o.robot.spec;
  ro.robot_file = o.robot.robot_file;
  ro.robot_file_text = o.robot.robot_file_text;
  ro.sim = o.robot.sim;
  ro.interactive = o.interactive;
  ro.input = o.input;
  ro.stop_flag = o.stop_flag;
  ro.calibration = calibration;
  const protocols::RunSummary s = protocols::RunProtocols({p}, robot, ro);
  (*runs)[p.name] = {{"status", s.status},
                     {"frames", s.num_frames},
                     {"clamped", s.num_clamped},
                     {"robot_clock_s", s.elapsed_s},
                     {"message", s.message}};
  // Step-response and latency trials keep servo traces and tables, not camera frames.
  if (o.progress)
    o.progress("  " + s.status + ", " +
               (s.num_frames > 0 ? std::to_string(s.num_frames) + " frames" : "no frames kept (tables only)") + ", " +
               std::to_string(s.num_clamped) + " clamped commands");
  if (s.status == "aborted") throw std::runtime_error("stopped by the user; datasets so far are in " + o.out);
  if (s.status != "complete") warnings->push_back("protocol " + p.name + ": " + s.status + ": " + s.message);
}

// FitGeometry's result with the progress lines it said while protocols were recording: they are
// said in one block when the fit is joined, so the terminal never interleaves two streams.
struct BufferedGeometryFit {
  evaluation::CalibrationRun run;
  std::vector<std::string> lines;
  evaluation::CalibrationRun Flush(const std::function<void(const std::string&)>& progress) {
    if (progress)
      for (const std::string& line : lines) progress(line);
    return std::move(run);
  }
};

// True when no protocol after loaded[i] records a dataset FitGeometry reads.
bool NoGeometryDatasetAfter(const std::vector<protocols::Protocol>& loaded, size_t i) {
  for (size_t j = i + 1; j < loaded.size(); ++j)
    if (GeometryDatasetNames().count(loaded[j].name)) return false;
  return true;
}

// FitGeometry on a thread of its own: it reads recorded datasets only (never the robot), so the
// protocols after them record while it runs; on a real robot its CPU time hides in the person's
// placements.
std::future<BufferedGeometryFit> StartGeometryFit(const std::map<std::string, std::string>& datasets,
                                                  CalibratePipelineOptions fit) {
  return std::async(std::launch::async, [datasets, fit]() mutable {
    BufferedGeometryFit out;
    if (fit.progress) fit.progress = [&out](const std::string& line) { out.lines.push_back(line); };
    out.run = FitGeometry(datasets, fit);
    return out;
  });
}

// Equal in everything the manifests record of a configuration.
bool SameConfig(const models::RobotConfig& a, const models::RobotConfig& b) {
  for (int s = 0; s < models::kNumServos; ++s) {
    const models::ServoConfig &x = a.servos[s], &y = b.servos[s];
    if (x.min_us != y.min_us || x.max_us != y.max_us || x.centre_us != y.centre_us || x.direction != y.direction ||
        x.nominal_deg_per_us != y.nominal_deg_per_us)
      return false;
  }
  return a.ipd_m == b.ipd_m && a.image_width == b.image_width && a.image_height == b.image_height &&
         a.swap_eyes == b.swap_eyes && a.mirror_stream == b.mirror_stream;
}

}  // namespace

CalibratePipelineOptions DefaultFitOptions() {
  CalibratePipelineOptions o;
  SetLensModel("auto", &o, nullptr);
  return o;
}

bool CalibrateOptions::Check(std::string* why) const {
  if (out.empty()) {
    *why = "out (the calibration folder) is empty";
    return false;
  }
  return fit.Check(why);
}

evaluation::LatencyTruth LatencyTruthOf(const sim::RobotTruth& truth) {
  evaluation::LatencyTruth t;
  t.fps = truth.stream.fps;
  t.latency_ms = truth.stream.latency_ms;
  t.eye_offset_ms = truth.stream.eye_offset_ms;
  t.rolling_shutter_ms = truth.stream.rolling_shutter_ms;
  t.drop_probability = truth.stream.drop_probability;
  for (int s = 0; s < models::kNumServos; ++s) {
    t.slew_deg_per_s[s] = truth.servos[s].slew_deg_per_s;
    t.lag_s[s] = truth.servos[s].lag_s;
  }
  t.head = truth.HeadModel();
  return t;
}

void SetTruth(const sim::RobotTruth& truth, CalibratePipelineOptions* o) {
  o->truth = truth.HeadModel();
  o->latency_truth = LatencyTruthOf(truth);
  o->fps = truth.stream.fps;
  for (int i = 0; i < models::kNumServos; ++i) o->truth_slew_deg_per_s[i] = truth.servos[i].slew_deg_per_s;
  o->truth_latency_s = truth.stream.latency_ms / 1000.0;
}

evaluation::CalibrationRun Calibrate(robot::RobotInterface& robot, const CalibrateOptions& o) {
  std::string why;
  if (!o.Check(&why)) throw std::invalid_argument("calibrate options: " + why);
  CalibratePipelineOptions fit = o.fit;
  fit.config = robot.Config();
  if (o.truth)
    SetTruth(*o.truth, &fit);
  else if (auto* owl = dynamic_cast<sim::VirtualOwl*>(&robot))
    SetTruth(owl->Truth(), &fit);
  fit.progress = o.progress;
  if (o.progress) o.progress("robot: " + robot.Describe());

  // 1) One dataset per protocol; a protocol with a saccade step needs the fit (3).
  const std::vector<std::string> names = o.protocols.empty() ? protocols::StandardProtocolNames() : o.protocols;
  std::map<std::string, std::string> datasets;
  nlohmann::json runs = nlohmann::json::object();
  std::vector<std::string> warnings;
  std::vector<std::pair<protocols::Protocol, std::string>> after_fit;
  robot::RobotInterface* current = &robot;  // after the bring-up: the robot on what it learned
  std::unique_ptr<robot::ReconfiguredRobot> learned;
  std::future<BufferedGeometryFit> geometry;  // the lens, stereo and head fits, beside the later protocols
  // Every protocol is read before the robot moves: a typo in the last one costs no robot time.
  std::vector<protocols::Protocol> loaded;
  for (const std::string& name : names)
    loaded.push_back(protocols::LoadProtocolFile(protocols::ResolveProtocolPath(name)));
  for (size_t i = 0; i < names.size(); ++i) {
    const std::string& name = names[i];
    const protocols::Protocol& p = loaded[i];
    const std::string dir = o.out + "/datasets/" + fs::path(name).stem().string();
    if (RunsAfterFit(p)) {
      after_fit.emplace_back(p, dir);
      continue;
    }
    Record(p, dir, std::nullopt, *current, o, &runs, &warnings);
    datasets[p.name] = dir;
    // The bring-up: what the limits protocol measured bounds and directs every protocol after it.
    if (p.name == "limits" && o.apply_bring_up && !fit.bring_up) {
      fit.bring_up = LearnFromLimitsDataset(fit.config, dir);
      fit.config = fit.bring_up->learned;
      learned = std::make_unique<robot::ReconfiguredRobot>(robot, fit.config);
      current = learned.get();
      if (o.progress)
        o.progress("  bring-up: " + std::to_string(fit.bring_up->findings.size()) +
                   " differences from the robot file, applied to the protocols after it");
    }
    if (!geometry.valid() && NoGeometryDatasetAfter(loaded, i)) geometry = StartGeometryFit(datasets, fit);
  }

  // 2) The fit, 3) the protocols that use it, 4) the evaluations of everything recorded.
  evaluation::CalibrationRun run = geometry.valid() ? geometry.get().Flush(fit.progress) : FitGeometry(datasets, fit);
  FitEvaluations(datasets, fit, &run);
  for (const auto& [p, dir] : after_fit) {
    Record(p,
           dir,
           ControllerCalibration(run, "this calibrate run's head fit and step-response motion fit"),
           *current,
           o,
           &runs,
           &warnings);
    datasets[p.name] = dir;
  }
  FinishCalibration(datasets, fit, &run);
  std::vector<protocols::ProtocolWork> work;
  run.result.diagnostics["person_work"] = CalibrateWorkJson(datasets, &work);
  if (o.progress) {
    o.progress("the person's work and the robot's time, counted from the datasets:");
    for (const std::string& line : protocols::WorkLines(work, false)) o.progress(line);
  }
  run.result.warnings.insert(run.result.warnings.begin(), warnings.begin(), warnings.end());
  run.settings = o.settings;
  run.settings["runs"] = runs;
  run.result.inputs["command"] = run.settings;
  return run;
}

std::optional<sim::RobotTruth> TruthFromManifest(const nlohmann::json& m, const std::string& path) {
  if (!m.contains("sim") || m["sim"].is_null()) return std::nullopt;
  const nlohmann::json& s = m["sim"];
  if (!s.contains("truth_json") || !s["truth_json"].contains("robot_truth"))
    throw std::runtime_error(path + ": field 'sim.truth_json.robot_truth' is missing (virtual Owl without its truth)");
  const std::string truth_file = s.value("truth_file", "");
  sim::RobotTruth truth = truth_file.empty() ? sim::DefaultRobotTruth() : sim::LoadRobotTruth(truth_file);
  const nlohmann::json robot = m.value("robot", nlohmann::json::object());
  if (!robot.value("robot_file", "").empty()) {
    const std::string source = path + ": field 'robot.robot_file_text'";
    try {
      truth.robot = robot::RobotConfigFromYaml(YAML::Load(robot.value("robot_file_text", "")), source);
    } catch (const YAML::Exception& e) {
      throw std::runtime_error(source + ": " + e.what());
    }
  }
  if (sim::RobotTruthJson(truth) != s["truth_json"]["robot_truth"])
    throw std::runtime_error(path + ": the truth rebuilt from sim.truth_file ('" + truth_file +
                             "') is not the one recorded in sim.truth_json: the file changed since the recording");
  return truth;
}

evaluation::CalibrationRun FitDatasets(const std::string& dir, const FitDatasetsOptions& o) {
  const std::map<std::string, std::string> datasets = FindDatasets(dir);
  // The robot and the truth, from the manifests (every dataset of one calibration was recorded
  // on one robot).
  CalibratePipelineOptions fit = o.fit;
  // The robot file's configuration is the one the limits dataset (the bring-up) was recorded
  // with; the datasets after it were recorded on what it learned, or (a recording without the
  // bring-up) on the file's.
  const auto limits = datasets.find("limits");
  const std::string file_dataset = limits != datasets.end() ? limits->second : datasets.begin()->second;
  const std::string file_manifest = file_dataset + "/manifest.json";
  const nlohmann::json mf = protocols::ReadManifest(file_dataset);
  fit.config = RobotConfigFromManifest(mf, file_manifest);
  const std::optional<sim::RobotTruth> truth = TruthFromManifest(mf, file_manifest);
  std::optional<BringUp> bring_up;
  if (limits != datasets.end()) {
    bring_up = LearnFromLimitsDataset(fit.config, limits->second);
    // Datasets recorded before the learned limits were rounded to the 5 us grid carry the
    // unrounded ones: the bring-up is learned as they were recorded.
    const BringUp legacy = LearnFromLimitsDataset(fit.config, limits->second, 1);
    for (const auto& [name, dataset] : datasets) {
      if (dataset == file_dataset) continue;
      const models::RobotConfig c =
          RobotConfigFromManifest(protocols::ReadManifest(dataset), dataset + "/manifest.json");
      if (SameConfig(c, legacy.learned) && !SameConfig(c, bring_up->learned)) {
        bring_up = legacy;
        break;
      }
    }
  }
  bool on_learned = false, on_file = false;
  for (const auto& [name, dataset] : datasets) {
    const nlohmann::json m = protocols::ReadManifest(dataset);
    if (m.value("status", "") != "complete" && o.progress)
      o.progress("dataset " + dataset + ": status '" + m.value("status", "") + "' (" + m.value("message", "") + ")");
    if (dataset == file_dataset) continue;
    const models::RobotConfig c = RobotConfigFromManifest(m, dataset + "/manifest.json");
    const bool file_config = SameConfig(c, fit.config), learned_config = bring_up && SameConfig(c, bring_up->learned);
    if (!file_config && !learned_config)
      throw std::runtime_error(dataset + "/manifest.json: field 'robot.config' is neither " + file_manifest +
                               "'s nor what the bring-up learned from it: the datasets were not recorded on one robot");
    on_learned |= learned_config && !file_config;
    on_file |= file_config && !learned_config;
  }
  if (on_learned && on_file)
    throw std::runtime_error(dir +
                             ": some datasets were recorded on the robot file's configuration and some on what "
                             "the bring-up learned (" +
                             file_manifest + "): not one calibrate run");
  // Applied as calibrate applied it: when the later datasets ran on it (or nothing differs).
  if (bring_up && !on_file) {
    fit.config = bring_up->learned;
    fit.bring_up = bring_up;
  }
  if (truth) SetTruth(*truth, &fit);
  fit.progress = o.progress;
  std::string why;
  if (!fit.Check(&why)) throw std::invalid_argument("fit options: " + why);
  if (o.progress) o.progress("robot: " + fit.config.name + (truth ? " (virtual Owl, truth from the manifest)" : ""));
  evaluation::CalibrationRun run = CalibrateFromDatasets(datasets, fit);
  run.result.diagnostics["person_work"] = CalibrateWorkJson(datasets);
  return run;
}

}  // namespace owlcal::pipeline
