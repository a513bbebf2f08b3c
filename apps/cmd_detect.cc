// owlcal detect: images, or a recorded dataset's frames -> observation CSV (calib/observation_io.h).
// A dataset folder (protocols/dataset.h) is re-detected frame by frame: each frame's JPEG split
// as the robot's stream is (manifest robot.config: mirror_stream, swap_eyes), and each corner
// keeps the frame's servo command, approach and time stamp, as the runner's own detection does.
#include <algorithm>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <regex>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "apps/command_registry.h"
#include "apps/image_inputs.h"
#include "calib/detector.h"
#include "calib/observation_io.h"
#include "calib/target_file.h"
#include "fitting/robot_config_json.h"
#include "protocols/dataset.h"

namespace owlcal::apps {
namespace {

namespace fs = std::filesystem;

struct DetectOptions {
  std::vector<std::string> inputs;
  std::string target_path;
  std::string out;
  std::string method = "auto";
  int half_window = 5;
  bool pairs = false;
  bool mirror = false;
  bool swap = false;
};

// Frame index from the digits in a file name ("left07.jpg" -> 7), or -1.
int NumberIn(const std::string& stem) {
  static const std::regex digits("([0-9]+)");
  std::smatch m;
  std::string last;
  for (auto it = std::sregex_iterator(stem.begin(), stem.end(), digits); it != std::sregex_iterator(); ++it)
    last = (*it)[1];
  return last.empty() ? -1 : std::stoi(last);
}

// Re-detects every recorded frame of the dataset `dir` (superseded frames of a resumed run are
// skipped, as everything downstream skips them).
int DetectDataset(const std::string& dir,
                  const calib::TargetFile& tf,
                  const calib::DetectorOptions& dopt,
                  const std::string& out) {
  const nlohmann::json manifest = protocols::ReadManifest(dir);
  models::RobotConfig config = models::DefaultRobotConfig();
  if (manifest.contains("robot") && manifest["robot"].contains("config"))
    config = fitting::RobotConfigFromJson(manifest["robot"]["config"]);
  std::vector<calib::CornerObservation> obs;
  int found = 0, tried = 0, skipped = 0;
  for (const protocols::FrameRecord& f : protocols::ReadFramesCsv(dir)) {
    if (f.step_index < 0) {
      ++skipped;
      continue;
    }
    const std::vector<uint8_t> jpeg = protocols::ReadFrameJpeg(dir, f.frame_index);
    const cv::Mat frame = cv::imdecode(jpeg, cv::IMREAD_COLOR);
    if (frame.empty()) throw std::runtime_error(protocols::FramePath(dir, f.frame_index) + ": not a decodable JPEG");
    cv::Mat eyes[2];
    calib::SplitStereoFrame(frame, config.mirror_stream, config.swap_eyes, &eyes[0], &eyes[1]);
    for (int eye = 0; eye < 2; ++eye) {
      ++tried;
      const calib::TargetDetection d = calib::DetectTarget(eyes[eye], tf.target, dopt);
      if (!d.found) continue;
      ++found;
      std::vector<calib::CornerObservation> o2 =
          calib::DetectionToObservations(d, tf.target, int(f.frame_index), eye, f.pwm_us, f.stamp_ns);
      for (auto& c : o2) c.approach = f.approach;
      obs.insert(obs.end(), o2.begin(), o2.end());
    }
  }
  calib::WriteObservationsCsv(out, obs);
  std::cout << "dataset " << dir << ": detected the target in " << found << " of " << tried << " eye images ("
            << skipped << " superseded frames skipped); " << obs.size()
            << " corners with their servo commands written to " << out << " (target '" << tf.target.id << "', unit "
            << tf.unit << ")\n";
  return found > 0 ? kExitOk : kExitFailed;
}

int RunDetect(const DetectOptions& o) {
  const calib::TargetFile tf = calib::LoadTargetFileWithUnit(o.target_path);
  calib::DetectorOptions dopt;
  if (o.method == "sb") {
    dopt.chessboard_method = calib::ChessboardMethod::kSectorBased;
  } else if (o.method == "classic") {
    dopt.chessboard_method = calib::ChessboardMethod::kClassic;
  } else if (o.method != "auto") {
    throw UsageError("--method must be auto, classic or sb, got '" + o.method + "'");
  }
  dopt.subpix_half_window = o.half_window;
  std::string why;
  if (!dopt.Check(&why)) throw UsageError(why);

  if (o.inputs.size() == 1 && fs::exists(fs::path(o.inputs[0]) / "manifest.json")) {
    if (o.pairs || o.mirror || o.swap)
      throw UsageError("a dataset's frames are split as its manifest says: --pairs, --mirror and --swap do not apply");
    return DetectDataset(o.inputs[0], tf, dopt, o.out);
  }
  for (const std::string& in : o.inputs)
    if (fs::exists(fs::path(in) / "manifest.json"))
      throw UsageError("'" + in + "' is a dataset: give it alone to re-detect its frames");
  const std::vector<fs::path> files = ImageFilesIn(o.inputs);

  std::vector<calib::CornerObservation> obs;
  int found = 0, tried = 0, sequential = 0, unreadable = 0, misnamed = 0;
  std::map<std::string, int> index_of_suffix;
  for (const fs::path& p : files) {
    const cv::Mat img = cv::imread(p.string(), cv::IMREAD_GRAYSCALE);
    if (img.empty()) {
      std::cerr << "warning: cannot read image " << p << ", skipped\n";
      ++unreadable;
      continue;
    }
    const std::string stem = p.stem().string();
    std::vector<std::pair<int, cv::Mat>> eyes;  // (eye, image)
    int frame = -1;
    const bool side_by_side = img.cols >= 2 * img.rows * 1.2 && img.cols % 2 == 0;
    if (side_by_side) {
      cv::Mat l, r;
      calib::SplitStereoFrame(img, o.mirror, o.swap, &l, &r);
      eyes = {{0, l}, {1, r}};
      frame = NumberIn(stem);
      if (frame < 0) frame = sequential;
    } else {
      std::string lower = stem;
      std::transform(lower.begin(), lower.end(), lower.begin(), ::tolower);
      int eye = 0;
      std::string suffix = lower;
      if (lower.rfind("left", 0) == 0) {
        suffix = lower.substr(4);
      } else if (lower.rfind("right", 0) == 0) {
        eye = 1;
        suffix = lower.substr(5);
      } else if (o.pairs) {
        std::cerr << "warning: " << p << ": --pairs expects left*/right* names, skipped\n";
        ++misnamed;
        continue;
      }
      if (o.pairs) {
        frame = NumberIn(suffix);
        if (frame < 0) {
          auto it = index_of_suffix.emplace(suffix, int(index_of_suffix.size())).first;
          frame = it->second;
        }
      } else {
        frame = sequential;
      }
      cv::Mat im = img;
      if (o.mirror) cv::flip(img, im, 1);
      eyes = {{eye, im}};
    }
    ++sequential;
    for (auto& [eye, im] : eyes) {
      ++tried;
      const calib::TargetDetection d = calib::DetectTarget(im, tf.target, dopt);
      std::cout << p.filename().string() << (side_by_side ? (eye == 0 ? " [left]" : " [right]") : "") << ": "
                << (d.found ? std::to_string(d.pixels.size()) + " corners" : "not found: " + d.message) << "\n";
      if (!d.found) continue;
      ++found;
      const auto o2 = calib::DetectionToObservations(d, tf.target, frame, eye);
      obs.insert(obs.end(), o2.begin(), o2.end());
    }
  }
  calib::WriteObservationsCsv(o.out, obs);
  std::cout << "detected the target in " << found << " of " << tried << " eye images; " << obs.size()
            << " corners written to " << o.out << " (target '" << tf.target.id << "', unit " << tf.unit << ")";
  if (unreadable > 0) std::cout << "; " << unreadable << " of " << files.size() << " files unreadable";
  if (misnamed > 0) std::cout << "; " << misnamed << " skipped for names other than left*/right*";
  std::cout << "\n";
  return found > 0 ? kExitOk : kExitFailed;
}

const bool kDetectRegistered = RegisterCommand(
    "detect",
    "Detect a chessboard/AprilGrid in images and write an observation CSV. Consumes image files or "
    "folders (left*/right* pairs, single-eye images, or 1280x480 side-by-side frames), or one recorded "
    "dataset folder (its frames re-detected, each corner keeping the frame's servo command); produces OBS.csv.",
    [](CLI::App* cmd) {
      auto o = std::make_shared<DetectOptions>();
      cmd->add_option("inputs", o->inputs, "image files and/or folders, or one dataset folder")->required();
      cmd->add_option("--target", o->target_path, "target file (data/targets/*.yaml)")->required();
      cmd->add_option("--out", o->out, "observation CSV to write")->required();
      cmd->add_option("--method",
                      o->method,
                      "chessboard detector: auto (classic, then sb: what every other command uses), classic "
                      "(findChessboardCorners + cornerSubPix) or sb; each also with rows and cols exchanged")
          ->capture_default_str();
      cmd->add_option("--subpix-half-window", o->half_window, "cornerSubPix half-window (default 5)");
      cmd->add_flag("--pairs", o->pairs, "images are left*/right* pairs; frame index from the number in the name");
      cmd->add_flag("--mirror", o->mirror, "flip each image (or side-by-side frame) horizontally first");
      cmd->add_flag("--swap", o->swap, "side-by-side frames: left eye is the right half");
      return [o] { return RunDetect(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
