#include "pipeline/calibrate.h"

#include <algorithm>
#include <filesystem>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include "pipeline/saccade_study.h"
#include "protocols/dataset.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "robot/robot_file.h"
#include "sim/virtual_owl.h"

namespace owlcal::pipeline {
namespace {

namespace fs = std::filesystem;

bool UsesCalibration(const protocols::Protocol& p) {
  return std::any_of(p.steps.begin(), p.steps.end(), [](const protocols::Step& st) {
    return st.kind() == protocols::StepKind::kSaccade;
  });
}

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

fitting::LatencyTruth LatencyTruthOf(const sim::RobotTruth& truth) {
  fitting::LatencyTruth t;
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

fitting::CalibrationRun Calibrate(robot::RobotInterface& robot, const CalibrateOptions& o) {
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
  robot::RobotInterface* current = &robot;
  // Every protocol is read before the robot moves: a typo in the last one costs no robot time.
  std::vector<protocols::Protocol> loaded;
  for (const std::string& name : names) loaded.push_back(protocols::LoadProtocolFile(protocols::ResolveProtocolPath(name)));
  for (size_t i = 0; i < names.size(); ++i) {
    const std::string& name = names[i];
    const protocols::Protocol& p = loaded[i];
    const std::string dir = o.out + "/datasets/" + fs::path(name).stem().string();
    if (UsesCalibration(p)) {
      after_fit.emplace_back(p, dir);
      continue;
    }
    Record(p, dir, std::nullopt, *current, o, &runs, &warnings);
    datasets[p.name] = dir;
  }

  // 2) The fit, 3) the protocols that use it, 4) the evaluations of everything recorded.
  fitting::CalibrationRun run = FitCalibration(datasets, fit);
  for (const auto& [p, dir] : after_fit) {
    Record(p, dir, ControllerCalibration(run, "this calibrate run's head fit and step-response motion fit"), *current,
           o, &runs, &warnings);
    datasets[p.name] = dir;
  }
  FinishCalibration(datasets, fit, &run);
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

fitting::CalibrationRun FitDatasets(const std::string& dir, const FitDatasetsOptions& o) {
  const std::map<std::string, std::string> datasets = FindDatasets(dir);
  // The robot and the truth, from the manifests (every dataset of one calibration was recorded
  // on one robot).
  CalibratePipelineOptions fit = o.fit;
  const std::string first_manifest = datasets.begin()->second + "/manifest.json";
  const nlohmann::json m0 = protocols::ReadManifest(datasets.begin()->second);
  fit.config = RobotConfigFromManifest(m0, first_manifest);
  const std::optional<sim::RobotTruth> truth = TruthFromManifest(m0, first_manifest);
  for (const auto& [name, dataset] : datasets) {
    const nlohmann::json m = protocols::ReadManifest(dataset);
    if (m.value("robot", nlohmann::json::object()).value("config", nlohmann::json()) != m0["robot"]["config"])
      throw std::runtime_error(dataset + "/manifest.json: field 'robot.config' differs from " + first_manifest +
                               "'s: the datasets were not recorded on one robot");
    if (m.value("status", "") != "complete" && o.progress)
      o.progress("dataset " + dataset + ": status '" + m.value("status", "") + "' (" + m.value("message", "") + ")");
  }
  if (truth) SetTruth(*truth, &fit);
  fit.progress = o.progress;
  std::string why;
  if (!fit.Check(&why)) throw std::invalid_argument("fit options: " + why);
  if (o.progress) o.progress("robot: " + fit.config.name + (truth ? " (virtual Owl, truth from the manifest)" : ""));
  return CalibrateFromDatasets(datasets, fit);
}

}  // namespace owlcal::pipeline
