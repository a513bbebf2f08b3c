#include "sim/scene.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include "io/strict_number.h"
#include "io/yaml_fields.h"
#include "models/units.h"

namespace owlcal::sim {
namespace {

// Base frame x right, y down, z forward: yaw turns about y (positive: +z towards +x, the
// board's face turns to the robot's right), pitch about x (positive: top edge away from the
// robot), roll about z (in the board's plane). R = Ry(yaw) Rx(pitch) Rz(roll).
Eigen::Matrix3d Rpy(double roll_deg, double pitch_deg, double yaw_deg) {
  return (Eigen::AngleAxisd(yaw_deg * kDeg, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(pitch_deg * kDeg, Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(roll_deg * kDeg, Eigen::Vector3d::UnitZ()))
      .toRotationMatrix();
}

const char* KindName(calib::TargetKind k) {
  switch (k) {
    case calib::TargetKind::kChessboard:
      return "chessboard";
    case calib::TargetKind::kAprilGrid:
      return "aprilgrid";
    case calib::TargetKind::kFixation:
      return "fixation";
  }
  return "?";
}

}  // namespace

Eigen::Isometry3d TargetMotion::Offset(int64_t t_ns) const {
  Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
  if (Still()) return m;
  static constexpr double kHz[4] = {0.7, 1.6, 3.1, 8.7};
  static constexpr double kShare[4] = {0.4, 0.3, 0.2, 0.1};
  const double t = double(t_ns) * 1e-9;
  uint64_t state = seed * 0x9E3779B97F4A7C15ull + 0x51ED27ull;
  auto phase = [&] {
    state += 0x9E3779B97F4A7C15ull;
    uint64_t z = state;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return double((z ^ (z >> 31)) >> 11) * 0x1.0p-53 * 2 * M_PI;
  };
  // Per axis: speed_axis^2 = speed^2 / 3; component k has speed variance share_k; a sinusoid of
  // amplitude A at angular frequency w has RMS speed A w / sqrt(2).
  Eigen::Vector3d p = Eigen::Vector3d::Zero(), r = Eigen::Vector3d::Zero();
  for (int axis = 0; axis < 3; ++axis)
    for (int k = 0; k < 4; ++k) {
      const double w = 2 * M_PI * kHz[k];
      const double a = std::sqrt(2 * kShare[k] / 3.0) / w;
      p[axis] += speed_m_s * a * std::sin(w * t + phase());
      r[axis] += angular_speed_deg_s * kDeg * a * std::sin(w * t + phase());
    }
  m.linear() =
      (r.norm() > 0 ? Eigen::AngleAxisd(r.norm(), r.normalized()) : Eigen::AngleAxisd::Identity()).toRotationMatrix();
  m.translation() = p;
  return m;
}

Eigen::Isometry3d SceneTarget::PoseAt(int64_t t_ns) const {
  return motion.Still() ? base_from_target : base_from_target * motion.Offset(t_ns);
}

Eigen::Vector4d SceneTarget::WarpSpan() const {
  Eigen::Vector4d span(1e30, -1e30, 1e30, -1e30);
  for (const auto& [id, p] : definition.Corners()) {
    span[0] = std::min(span[0], p.x());
    span[1] = std::max(span[1], p.x());
    span[2] = std::min(span[2], p.y());
    span[3] = std::max(span[3], p.y());
  }
  return span;
}

Eigen::Vector3d SceneTarget::WarpedPoint(const Eigen::Vector3d& p) const {
  if (warp_m.x() == 0 && warp_m.y() == 0) return p;
  const Eigen::Vector4d s = WarpSpan();
  const double u = (p.x() - (s[0] + s[1]) / 2) / std::max(1e-12, (s[1] - s[0]) / 2);
  const double v = (p.y() - (s[2] + s[3]) / 2) / std::max(1e-12, (s[3] - s[2]) / 2);
  return Eigen::Vector3d(p.x(), p.y(), p.z() - (warp_m.x() * (1 - u * u) + warp_m.y() * (1 - v * v)));
}

SceneDescription SceneDescription::At(int64_t t_ns) const {
  SceneDescription s = *this;
  for (SceneTarget& t : s.targets) {
    t.base_from_target = t.PoseAt(t_ns);
    t.motion = TargetMotion();
  }
  return s;
}

SceneTarget* SceneDescription::Find(const std::string& name) {
  for (SceneTarget& t : targets)
    if (t.name() == name) return &t;
  return nullptr;
}
const SceneTarget* SceneDescription::Find(const std::string& name) const {
  for (const SceneTarget& t : targets)
    if (t.name() == name) return &t;
  return nullptr;
}

Eigen::Isometry3d FacingPose(const calib::TargetDefinition& def,
                             const Eigen::Vector3d& centre_in_base,
                             double yaw_deg,
                             double pitch_deg,
                             double roll_deg) {
  const Eigen::Vector4d e = def.Extent();
  Eigen::Vector3d centre_in_target(0, 0, 0);
  if (def.kind == calib::TargetKind::kChessboard) {
    centre_in_target = Eigen::Vector3d((def.cols - 1) * def.square_m / 2, (def.rows - 1) * def.square_m / 2, 0);
  } else if (def.kind == calib::TargetKind::kAprilGrid) {
    centre_in_target = Eigen::Vector3d((e[0] + e[1]) / 2, (e[2] + e[3]) / 2, 0);
  }
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Rpy(roll_deg, pitch_deg, yaw_deg);
  pose.translation() = centre_in_base - pose.linear() * centre_in_target;
  return pose;
}

calib::TargetDefinition TagSheetDefinition(const std::string& name, int first_id) {
  calib::TargetDefinition d;
  d.id = name;
  d.kind = calib::TargetKind::kAprilGrid;
  d.tag_cols = 6;
  d.tag_rows = 2;
  d.tag_size_m = 0.045;
  d.tag_spacing = 0.25;
  d.first_id = first_id;
  return d;
}

SceneDescription DefaultScene() {
  SceneDescription s;
  SceneTarget chess;
  chess.definition.id = "chessboard";
  chess.definition.kind = calib::TargetKind::kChessboard;
  chess.definition.cols = 9;
  chess.definition.rows = 6;
  chess.definition.square_m = 0.026;
  chess.base_from_target = FacingPose(chess.definition, {0.0, 0.0, 0.63});
  chess.warp_m = Eigen::Vector2d(kCourseBoardWarpM, 0);
  s.targets.push_back(chess);

  SceneTarget grid;
  grid.definition.id = "aprilgrid";
  grid.definition.kind = calib::TargetKind::kAprilGrid;
  grid.definition.tag_cols = 6;
  grid.definition.tag_rows = 6;
  grid.definition.tag_size_m = 0.024;
  grid.definition.tag_spacing = 0.3;
  grid.base_from_target = FacingPose(grid.definition, {0.42, 0.0, 0.55}, 35.0);
  s.targets.push_back(grid);

  // Tag sheets around the boards (protocols/standard/servo_sweep.yaml `tag_targets`): four 6x2
  // grids of 45 mm tag36h11 tags (ids from 100, 12 per sheet), 0.7 m from the neck axis at 22 deg
  // azimuth and 15 deg elevation, above and below each side, facing the head. They stay in view
  // where the chessboard leaves it (pans, tilts and the neck near their ends) and inside the
  // socket rims of robots whose rim hides the side chessboards.
  const struct {
    const char* name;
    Eigen::Vector3d centre_m;  // 0.7 m from the neck axis at the azimuth and elevation below
    double azimuth_deg, elevation_deg;
    int first_id;
  } kSheets[] = {{"tags_right_up", {0.253, -0.181, 0.627}, 22, 15, 100},
                 {"tags_right_down", {0.253, 0.181, 0.627}, 22, -15, 112},
                 {"tags_left_up", {-0.253, -0.181, 0.627}, -22, 15, 124},
                 {"tags_left_down", {-0.253, 0.181, 0.627}, -22, -15, 136}};
  for (const auto& sheet : kSheets) {
    SceneTarget tags;
    tags.definition = TagSheetDefinition(sheet.name, sheet.first_id);
    tags.base_from_target = FacingPose(tags.definition, sheet.centre_m, sheet.azimuth_deg, sheet.elevation_deg);
    s.targets.push_back(tags);
  }

  SceneTarget fix;
  fix.definition.id = "fixation";
  fix.definition.kind = calib::TargetKind::kFixation;
  fix.definition.fixation_radius_m = 0.012;
  fix.base_from_target = FacingPose(fix.definition, {-0.40, 0.0, 0.9}, -24.0);
  s.targets.push_back(fix);
  return s;
}

nlohmann::json PoseJson(const Eigen::Isometry3d& pose) {
  const Eigen::Quaterniond q(pose.linear());
  const Eigen::Vector3d t = pose.translation();
  return {{"t_m", {t.x(), t.y(), t.z()}}, {"q_xyzw", {q.x(), q.y(), q.z(), q.w()}}};
}

Eigen::Isometry3d PoseFromJson(const nlohmann::json& j) {
  if (!j.is_object())
    throw std::invalid_argument("pose: expected an object with t_m and q_xyzw or rpy_deg, got " + j.dump());
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  auto vec = [&](const char* key, size_t n) {
    const nlohmann::json& v = j.at(key);
    if (!v.is_array() || v.size() != n) {
      throw std::invalid_argument(std::string("pose.") + key + ": expected " + std::to_string(n) + " numbers, got " +
                                  v.dump());
    }
    std::vector<double> out;
    for (const auto& x : v) {
      if (!x.is_number())
        throw std::invalid_argument(std::string("pose.") + key + ": '" + x.dump() + "' is not a number");
      out.push_back(x.get<double>());
    }
    return out;
  };
  if (!j.contains("t_m")) throw std::invalid_argument("pose.t_m: missing in " + j.dump());
  const auto t = vec("t_m", 3);
  pose.translation() = Eigen::Vector3d(t[0], t[1], t[2]);
  if (j.contains("q_xyzw")) {
    const auto q = vec("q_xyzw", 4);
    const Eigen::Quaterniond qq(q[3], q[0], q[1], q[2]);
    if (qq.norm() < 1e-9) throw std::invalid_argument("pose.q_xyzw: zero quaternion");
    pose.linear() = qq.normalized().toRotationMatrix();
  } else if (j.contains("rpy_deg")) {
    const auto r = vec("rpy_deg", 3);
    pose.linear() = Rpy(r[0], r[1], r[2]);
  }
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(pose.translation()[i])) throw std::invalid_argument("pose.t_m: not finite");
  return pose;
}

nlohmann::json SceneJson(const SceneDescription& scene) {
  nlohmann::json j;
  const Background& b = scene.background;
  j["background"] = {{"distance_m", b.distance_m},
                     {"texel_m", b.texel_m},
                     {"contrast", b.contrast},
                     {"grey", b.grey},
                     {"seed", b.seed}};
  j["targets"] = nlohmann::json::array();
  for (const SceneTarget& t : scene.targets) {
    const calib::TargetDefinition& d = t.definition;
    nlohmann::json o = {
        {"name", d.id}, {"kind", KindName(d.kind)}, {"visible", t.visible}, {"pose", PoseJson(t.base_from_target)}};
    if (t.warp_m.x() != 0 || t.warp_m.y() != 0) o["warp_m"] = {t.warp_m.x(), t.warp_m.y()};
    if (!t.motion.Still()) {
      o["motion"] = {{"speed_m_s", t.motion.speed_m_s},
                     {"angular_speed_deg_s", t.motion.angular_speed_deg_s},
                     {"seed", t.motion.seed}};
    }
    if (d.kind == calib::TargetKind::kChessboard) {
      o["cols"] = d.cols;
      o["rows"] = d.rows;
      o["square_m"] = d.square_m;
    } else if (d.kind == calib::TargetKind::kAprilGrid) {
      o["tag_cols"] = d.tag_cols;
      o["tag_rows"] = d.tag_rows;
      o["tag_size_m"] = d.tag_size_m;
      o["tag_spacing"] = d.tag_spacing;
      o["first_id"] = d.first_id;
      o["family"] = d.family;
    } else {
      o["fixation_radius_m"] = d.fixation_radius_m;
    }
    j["targets"].push_back(o);
  }
  return j;
}

SceneDescription LoadScene(const std::string& path) {
  io::YamlFields f(io::LoadYamlFile(path, "scene file"), path);
  SceneDescription s;
  if (auto b = f.OptionalMap("background")) {
    Background& g = s.background;
    g.distance_m = b->Number("distance_m", g.distance_m, 0.2, 1e3);
    g.texel_m = b->Number("texel_m", g.texel_m, 1e-5, 1);
    g.contrast = b->Number("contrast", g.contrast, 0, 1);
    g.grey = b->Number("grey", g.grey, 0, 1);
    g.seed = static_cast<uint64_t>(b->Int("seed", static_cast<int>(g.seed), 0, INT32_MAX));
    b->RejectUnknown();
  }
  std::set<std::string> names;
  const YAML::Node list = f.Get("targets");
  if (list.IsDefined() && !list.IsSequence()) f.Fail("targets", "must be a list of targets");
  f.RejectUnknown();
  for (size_t index = 0; list.IsDefined() && index < list.size(); ++index) {
    io::YamlFields n(list[index], path, "targets[" + std::to_string(index) + "]");
    SceneTarget t;
    calib::TargetDefinition& d = t.definition;
    d.id = n.String("name");
    if (d.id.empty() || !names.insert(d.id).second)
      n.Fail("name", "= '" + io::Printable(d.id) + "' is empty or not unique");
    const std::string kind = n.String("kind", "chessboard");
    if (kind == "chessboard")
      d.kind = calib::TargetKind::kChessboard;
    else if (kind == "aprilgrid")
      d.kind = calib::TargetKind::kAprilGrid;
    else if (kind == "fixation")
      d.kind = calib::TargetKind::kFixation;
    else
      n.Fail("kind", "= '" + io::Printable(kind) + "' is not chessboard, aprilgrid or fixation");
    d.cols = n.Int("cols", d.cols, 2, 100);
    d.rows = n.Int("rows", d.rows, 2, 100);
    d.square_m = n.Number("square_m", d.square_m, 1e-4, 10);
    d.tag_cols = n.Int("tag_cols", d.tag_cols, 1, 100);
    d.tag_rows = n.Int("tag_rows", d.tag_rows, 1, 100);
    d.tag_size_m = n.Number("tag_size_m", d.tag_size_m, 1e-4, 10);
    d.tag_spacing = n.Number("tag_spacing", d.tag_spacing, 0.125, 10);
    d.first_id = n.Int("first_id", d.first_id, 0, 100000);
    d.family = n.String("family", d.family);
    if (d.family != "tag36h11")
      n.Fail("family", "= '" + io::Printable(d.family) + "' is not supported (only tag36h11)");
    d.fixation_radius_m = n.Number("fixation_radius_m", d.fixation_radius_m, 1e-4, 10);
    t.visible = n.Bool("visible", t.visible);
    if (n.Has("warp_m")) {
      // Bow of the board towards the camera along x and y (SceneTarget::warp_m), within 5 cm.
      const auto w = n.Numbers("warp_m", 2, -0.05, 0.05);
      t.warp_m = Eigen::Vector2d(w[0], w[1]);
    }
    if (auto m = n.OptionalMap("motion")) {
      t.motion.speed_m_s = m->Number("speed_m_s", 0, 2);
      t.motion.angular_speed_deg_s = m->Number("angular_speed_deg_s", 0, 360);
      t.motion.seed = static_cast<uint64_t>(m->Int("seed", 0, 0, 1 << 30));
      m->RejectUnknown();
    }
    if (auto p = n.OptionalMap("pose")) {
      // Positions within 1 km of the head, angles within one turn.
      if (p->Has("centre_m")) {
        // The board's centre and its turn (FacingPose).
        const auto c = p->Numbers("centre_m", 3, -kMaxTargetOffset_m, kMaxTargetOffset_m);
        const auto r = p->Has("rpy_deg") ? p->Numbers("rpy_deg", 3, -360, 360) : std::vector<double>{0, 0, 0};
        t.base_from_target = FacingPose(d, Eigen::Vector3d(c[0], c[1], c[2]), r[2], r[1], r[0]);
      } else {
        nlohmann::json j;
        j["t_m"] = p->Numbers("t_m", 3, -kMaxTargetOffset_m, kMaxTargetOffset_m);
        if (p->Has("q_xyzw")) j["q_xyzw"] = p->Numbers("q_xyzw", 4, -1, 1);
        if (p->Has("rpy_deg")) j["rpy_deg"] = p->Numbers("rpy_deg", 3, -360, 360);
        try {
          t.base_from_target = PoseFromJson(j);
        } catch (const std::exception& e) {
          p->Fail("q_xyzw", std::string("gives no pose: ") + e.what());
        }
      }
      p->RejectUnknown();
    }
    n.RejectUnknown();
    s.targets.push_back(t);
  }
  return s;
}

}  // namespace owlcal::sim
