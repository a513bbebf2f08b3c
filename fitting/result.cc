#include "fitting/result.h"

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "io/atomic_file.h"
#include "io/json_strict.h"

namespace owlcal::fitting {
namespace {

using nlohmann::json;

double NumOr(const json& j, const char* key, double dflt = std::numeric_limits<double>::quiet_NaN()) {
  if (!j.contains(key) || j.at(key).is_null()) return dflt;
  return j.at(key).get<double>();
}

json PoseJson(const models::Rigid3d& p) {
  double a[7];
  p.ToArray(a);
  return json::array({a[0], a[1], a[2], a[3], a[4], a[5], a[6]});
}
models::Rigid3d PoseFromJson(const json& j) {
  double a[7];
  for (int i = 0; i < 7; ++i) a[i] = j.at(i).get<double>();
  return models::Rigid3d::Map(a);
}

json CameraJson(const models::CameraIntrinsics& c) {
  return {{"model", c.model == models::DistortionModel::kOpenCv5 ? "opencv5" : "opencv8"},
          {"width", c.width},
          {"height", c.height},
          {"params", c.params}};
}
models::CameraIntrinsics CameraFromJson(const json& j) {
  models::CameraIntrinsics c;
  const std::string m = j.at("model").get<std::string>();
  if (m != "opencv5" && m != "opencv8") throw std::runtime_error("camera model '" + m + "' unknown");
  c.model = m == "opencv5" ? models::DistortionModel::kOpenCv5 : models::DistortionModel::kOpenCv8;
  c.width = j.at("width").get<int>();
  c.height = j.at("height").get<int>();
  if (c.width < 1 || c.height < 1 || c.width > 16384 || c.height > 16384)
    throw std::runtime_error("camera size " + std::to_string(c.width) + "x" + std::to_string(c.height) +
                             " is not within 1..16384");
  // NaN is written as null: a null parameter is refused here, by name.
  const json& params = j.at("params");
  if (!params.is_array()) throw std::runtime_error("camera params: expected a list of numbers");
  static const char* kNames[] = {"fx", "fy", "cx", "cy"};
  c.params.clear();
  for (size_t i = 0; i < params.size(); ++i) {
    const std::string name = "params[" + std::to_string(i) + "]" + (i < 4 ? std::string(" (") + kNames[i] + ")" : "");
    if (!params[i].is_number())
      throw std::runtime_error("camera " + name + " is " + params[i].dump() + ", not a number");
    c.params.push_back(params[i].get<double>());
  }
  if (int(c.params.size()) != 4 + c.NumDistortion()) throw std::runtime_error("camera params has wrong length");
  // A focal length of 0 gave calibration.yaml full of NaN: refuse it here.
  for (int i = 0; i < 2; ++i)
    if (!(c.params[i] > 0))
      throw std::runtime_error(std::string("camera params[") + std::to_string(i) + "] (" + kNames[i] +
                               ") = " + std::to_string(c.params[i]) + " must be > 0");
  return c;
}

json HeadJson(const models::HeadModel& h) {
  json servos = json::array();
  for (int i = 0; i < models::kNumServos; ++i) {
    servos.push_back({{"name", models::kServoNames[i]},
                      {"direction", h.directions[i]},
                      {"params", std::vector<double>(h.servo_params[i].begin(), h.servo_params[i].end())}});
  }
  json j = {{"servos", servos}};
  for (int e = 0; e < 2; ++e) {
    j[models::kEyeNames[e]] = {
        {"centre_in_head_m",
         {h.geometry.centre_in_head[e].x(), h.geometry.centre_in_head[e].y(), h.geometry.centre_in_head[e].z()}},
        {"cam_from_eye", PoseJson(h.geometry.cam_from_eye[e])},
        {"camera", CameraJson(h.intrinsics[e])}};
  }
  return j;
}
models::HeadModel HeadFromJson(const json& j) {
  models::HeadModel h;
  const json& servos = j.at("servos");
  if (servos.size() != models::kNumServos) throw std::runtime_error("head.servos must have 5 entries");
  for (int i = 0; i < models::kNumServos; ++i) {
    h.directions[i] = servos[i].at("direction").get<int>();
    const auto p = servos[i].at("params").get<std::vector<double>>();
    if (p.size() != models::ServoMap::kNumParams) throw std::runtime_error("head.servos[].params must have 5 values");
    std::copy(p.begin(), p.end(), h.servo_params[i].begin());
  }
  for (int e = 0; e < 2; ++e) {
    const json& je = j.at(models::kEyeNames[e]);
    const auto c = je.at("centre_in_head_m").get<std::vector<double>>();
    h.geometry.centre_in_head[e] = Eigen::Vector3d(c.at(0), c.at(1), c.at(2));
    h.geometry.cam_from_eye[e] = PoseFromJson(je.at("cam_from_eye"));
    h.intrinsics[e] = CameraFromJson(je.at("camera"));
  }
  return h;
}

}  // namespace

const Parameter* CalibrationResult::Find(const std::string& name) const {
  for (const Parameter& p : parameters)
    if (p.name == name) return &p;
  return nullptr;
}

Parameter& CalibrationResult::Set(const Parameter& p) {
  for (Parameter& q : parameters)
    if (q.name == p.name) return q = p;
  parameters.push_back(p);
  return parameters.back();
}

json ToJson(const CalibrationResult& r) {
  json j;
  j["software"] = {{"name", "owlcal"}, {"version", r.software_version}};
  if (!r.run_id.empty()) j["run_id"] = r.run_id;
  j["parameters"] = json::array();
  for (const Parameter& p : r.parameters) {
    json jp = {{"name", p.name},
               {"value", io::JsonNumber(p.value)},
               {"sigma", io::JsonNumber(p.sigma)},
               {"unit", p.unit},
               {"determined", p.determined}};
    if (p.truth) jp["truth"] = io::JsonNumber(*p.truth);
    if (!p.note.empty()) jp["note"] = p.note;
    if (p.held) jp["held"] = true;
    j["parameters"].push_back(jp);
  }
  j["solver"] = json::array();
  for (const SolveSummary& s : r.summaries) {
    j["solver"].push_back({{"problem", s.problem},
                           {"termination", s.termination},
                           {"message", s.message},
                           {"initial_cost", io::JsonNumber(s.initial_cost)},
                           {"final_cost", io::JsonNumber(s.final_cost)},
                           {"iterations", s.iterations},
                           {"time_s", io::JsonNumber(s.time_s)},
                           {"rms_px", io::JsonNumber(s.rms_px)},
                           {"num_residuals", s.num_residuals},
                           {"num_outliers", s.num_outliers},
                           {"usable", s.usable}});
  }
  j["warnings"] = r.warnings;
  j["notes"] = r.notes;
  if (!r.verdict.is_null()) j["verdict"] = r.verdict;
  for (int e = 0; e < 2; ++e)
    if (r.cameras[e]) j["cameras"][models::kEyeNames[e]] = CameraJson(*r.cameras[e]);
  if (r.stereo) {
    std::vector<double> cov(r.stereo->covariance.data(), r.stereo->covariance.data() + 36);
    j["stereo"] = {{"right_from_left", PoseJson(r.stereo->right_from_left)}, {"covariance", cov}};
    const Eigen::MatrixXd& F = r.stereo->full_covariance;
    if (F.rows() > 0 && F.rows() == F.cols() && F.rows() == Eigen::Index(r.stereo->full_names.size())) {
      nlohmann::json rows = nlohmann::json::array();
      for (Eigen::Index i = 0; i < F.rows(); ++i) {
        std::vector<double> row(F.cols());
        for (Eigen::Index k = 0; k < F.cols(); ++k) row[k] = F(i, k);
        rows.push_back(row);
      }
      j["stereo"]["full_covariance"] = {{"names", r.stereo->full_names}, {"matrix", rows}};
    }
  }
  if (r.head) j["head"] = HeadJson(*r.head);
  j["inputs"] = r.inputs;
  j["diagnostics"] = r.diagnostics;
  return j;
}

CalibrationResult ResultFromJson(const json& j) {
  CalibrationResult r;
  if (j.contains("software")) r.software_version = j.at("software").value("version", "");
  if (j.contains("run_id")) {
    if (!j.at("run_id").is_string()) throw std::runtime_error("field 'run_id' is not a string");
    r.run_id = j.at("run_id").get<std::string>();
  }
  for (const json& jp : j.at("parameters")) {
    Parameter p;
    p.name = jp.at("name").get<std::string>();
    p.value = NumOr(jp, "value");
    p.sigma = NumOr(jp, "sigma");
    p.unit = jp.value("unit", "");
    p.determined = jp.value("determined", true);
    p.note = jp.value("note", "");
    p.held = jp.value("held", false);
    if (jp.contains("truth") && !jp.at("truth").is_null()) p.truth = jp.at("truth").get<double>();
    r.parameters.push_back(p);
  }
  if (j.contains("solver")) {
    for (const json& js : j.at("solver")) {
      SolveSummary s;
      s.problem = js.value("problem", "");
      s.termination = js.value("termination", "");
      s.message = js.value("message", "");
      s.initial_cost = NumOr(js, "initial_cost");
      s.final_cost = NumOr(js, "final_cost");
      s.iterations = js.value("iterations", 0);
      s.time_s = NumOr(js, "time_s");
      s.rms_px = NumOr(js, "rms_px");
      s.num_residuals = js.value("num_residuals", 0);
      s.num_outliers = js.value("num_outliers", 0);
      s.usable = js.value("usable", false);
      r.summaries.push_back(s);
    }
  }
  if (j.contains("warnings")) r.warnings = j.at("warnings").get<std::vector<std::string>>();
  if (j.contains("notes")) r.notes = j.at("notes").get<std::vector<std::string>>();
  if (j.contains("verdict")) r.verdict = j.at("verdict");
  if (j.contains("cameras"))
    for (int e = 0; e < 2; ++e)
      if (j.at("cameras").contains(models::kEyeNames[e])) try {
          r.cameras[e] = CameraFromJson(j.at("cameras").at(models::kEyeNames[e]));
        } catch (const std::exception& ex) {
          throw std::runtime_error(std::string("cameras.") + models::kEyeNames[e] + ": " + ex.what());
        }
  if (j.contains("stereo")) {
    StereoEstimate s;
    s.right_from_left = PoseFromJson(j.at("stereo").at("right_from_left"));
    const auto cov = j.at("stereo").at("covariance").get<std::vector<double>>();
    if (cov.size() == 36) s.covariance = Eigen::Map<const Eigen::Matrix<double, 6, 6>>(cov.data());
    if (j.at("stereo").contains("full_covariance")) {
      const auto& fc = j.at("stereo").at("full_covariance");
      s.full_names = fc.at("names").get<std::vector<std::string>>();
      const auto rows = fc.at("matrix").get<std::vector<std::vector<double>>>();
      const Eigen::Index n = Eigen::Index(s.full_names.size());
      if (Eigen::Index(rows.size()) != n)
        throw std::runtime_error("stereo.full_covariance.matrix: " + std::to_string(rows.size()) + " rows for " +
                                 std::to_string(n) + " names");
      s.full_covariance.resize(n, n);
      for (Eigen::Index i = 0; i < n; ++i) {
        if (Eigen::Index(rows[i].size()) != n)
          throw std::runtime_error("stereo.full_covariance.matrix: row " + std::to_string(i) + " has " +
                                   std::to_string(rows[i].size()) + " values, not " + std::to_string(n));
        for (Eigen::Index k = 0; k < n; ++k) s.full_covariance(i, k) = rows[i][k];
      }
    }
    r.stereo = s;
  }
  if (j.contains("head")) r.head = HeadFromJson(j.at("head"));
  if (j.contains("inputs")) r.inputs = j.at("inputs");
  if (j.contains("diagnostics")) r.diagnostics = j.at("diagnostics");
  return r;
}

void WriteResultJson(const CalibrationResult& r, const std::string& path) {
  io::WriteFileAtomic(path, ToJson(r).dump(2) + "\n");
}

CalibrationResult ReadResultJson(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw std::runtime_error("cannot open result file " + path);
  std::ostringstream text;
  text << f.rdbuf();
  json j;
  try {
    j = io::ParseJsonStrict(text.str(), path);  // repeated keys are errors
    return ResultFromJson(j);
  } catch (const std::exception& e) {
    throw std::runtime_error("result file " + path + ": " + e.what());
  }
}

}  // namespace owlcal::fitting
