#pragma once
// A recorded dataset on disk: the contract between capturing (protocols/) and everything
// downstream (calib/ detection, fitting/, reports/). Everything downstream runs from a
// dataset alone, with no robot.
//
// Layout of a dataset folder DIR:
//   manifest.json    {"format": "owlcal-dataset", "format_version": 1, "owlcal_version",
//                     "created_utc", "finished_utc", "status": "running" | "complete" |
//                     "aborted" | "failed", "message", "robot": {"spec", "description",
//                     "robot_file", "robot_file_text", "config": {...limits...}},
//                     "protocols": [{"file", "name", "target", "text"}],
//                     "sim": {"seed", "truth_file", "truth_json"} (virtual Owl only),
//                     "num_steps", "num_frames" (when finished)}. Rewritten atomically
//                     (tmp + rename).
//   frames/NNNNNN.jpg  the raw side-by-side JPEG exactly as received (1280x480), NNNNNN =
//                     frame_index zero-padded to 6 digits.
//   frames.csv       one line per frame, appended and flushed after its JPEG is in place:
//                     frame_index,seq,stamp_ns,Rx_us,Ry_us,Lx_us,Ly_us,Neck_us,
//                     approach_Rx,approach_Ry,approach_Lx,approach_Ly,approach_Neck,
//                     step_index,step_name,placement_index,jpeg_bytes,jpeg_crc32
//                     pwm = the command in force when the frame was received (after the
//                     limits guard); approach = sign of that servo's last change (+1 up,
//                     -1 down, 0 unknown); placement_index = row of placements.csv in force
//                     (-1 none); jpeg_crc32 in hex (IEEE 802.3 polynomial, as zlib's crc32).
//   placements.csv   placement_index,step_index,target,distance_m,tx_m,ty_m,tz_m,qx,qy,qz,qw,
//                     source,answer,stamp_ns — the pose base_from_target (base frame of
//                     models/head_kinematics.h: origin on the neck axis at eye height) of the
//                     target's origin; source = "scene" (moved by the runner on a virtual
//                     robot), "prompt" (a person placed it and answered), or "file"
//                     (non-interactive run: the value of the protocol file is assumed).
//   steps.csv        step_index,step_name,kind,status,start_ns,end_ns,num_frames — one line
//                     per finished step ("done" or "failed"); resume continues after the last
//                     done step.
//   events.log       stamp_ns<TAB>kind<TAB>message: progress, clamps, prompts, aborts.
//   superseded/      after --resume: the rows the interrupted step had written to
//                     observations.csv and the measurement tables (its frames stay in
//                     frames.csv with step_index -1, step_name "superseded:<name>").
//   observations.csv (calib/observation_io.h) when the protocol ran detection.
//   Measurement tables written by closed-loop steps (all CSV with a header row):
//     fixations.csv      fixate steps: one row per fixation (vergence ranging).
//     step_response.csv  per-frame target offset of each step (gain, amplitude, trial).
//     step_trials.csv    one row per step-response trial (gain, amplitude, outcome).
//     limits.csv         limits validation: per servo and end the configured and measured limit.
//     resolution.csv     limits validation: the fine sweep that shows each servo's PWM step and dead band.
//     alignment.csv      roll and vertical offset between the eyes at the centre pose.
//     latency.csv        commanded step -> first image motion, per trial.
//     coverage.csv       per eye X/Y/Size/Skew coverage of the detected boards (intrinsics).
//   Their columns are listed by the step that writes them (protocols/runner.h).
//
// Crash safety: a JPEG is written to frames/NNNNNN.jpg.tmp-PID, closed and renamed, and only
// then is its frames.csv line appended and flushed. Every CSV line is written with one
// fwrite + fflush. A run killed at any moment therefore leaves complete lines for every
// frame but possibly the last, whose line may be missing or cut short; CheckDataset accepts
// that (drops the partial line and any orphan frame file) and RepairDataset makes it clean.
#include <array>
#include <cstdint>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "calib/csv.h"
#include "models/robot_config.h"

namespace owlcal::protocols {

inline constexpr const char* kDatasetFormat = "owlcal-dataset";
inline constexpr int kDatasetFormatVersion = 1;

// CRC-32 (IEEE, as zlib's crc32) of a byte buffer.
uint32_t Crc32(const uint8_t* data, size_t size);

// The path of frame `frame_index`: DIR/frames/NNNNNN.jpg.
std::string FramePath(const std::string& dir, int64_t frame_index);

struct FrameRecord {
  int64_t frame_index = 0;
  int64_t seq = 0;
  int64_t stamp_ns = 0;
  models::PwmVector pwm_us{};
  std::array<int8_t, models::kNumServos> approach{};
  int step_index = -1;
  std::string step_name;
  int placement_index = -1;
  int64_t jpeg_bytes = 0;
  uint32_t jpeg_crc32 = 0;
};

struct PlacementRecord {
  int placement_index = 0;
  int step_index = -1;
  std::string target;
  double distance_m = 0;
  Eigen::Isometry3d base_from_target = Eigen::Isometry3d::Identity();
  std::string source;  // scene | prompt | file
  std::string answer;  // what the person typed ("" = accepted the planned value)
  int64_t stamp_ns = 0;
};

struct StepRecord {
  int step_index = 0;
  std::string step_name;
  std::string kind;
  std::string status;  // done | failed
  int64_t start_ns = 0, end_ns = 0;
  int64_t num_frames = 0;
};

// Appends to a dataset. Not thread-safe. Throws std::runtime_error naming the path on any
// I/O failure.
class DatasetWriter {
 public:
  // Creates DIR (must not contain a manifest yet) and writes the manifest (status running).
  static std::unique_ptr<DatasetWriter> Create(const std::string& dir, nlohmann::json manifest);
  // Repairs DIR (RepairDataset) and opens it for appending; frame numbering continues.
  static std::unique_ptr<DatasetWriter> Resume(const std::string& dir);
  ~DatasetWriter();

  const std::string& Dir() const { return dir_; }
  nlohmann::json& Manifest() { return manifest_; }
  void WriteManifest();  // atomically rewrites manifest.json
  // Sets status (+ finished_utc, message) and rewrites the manifest.
  void Finish(const std::string& status, const std::string& message);

  // Writes the JPEG (tmp + rename) then appends its line. record.frame_index, jpeg_bytes
  // and jpeg_crc32 are filled in here; returns the frame index.
  int64_t AppendFrame(const std::vector<uint8_t>& jpeg, FrameRecord record);
  int64_t NumFrames() const { return next_frame_index_; }

  int AppendPlacement(PlacementRecord placement);  // returns its placement_index
  int NumPlacements() const { return next_placement_index_; }
  const std::vector<PlacementRecord>& Placements() const { return placements_; }
  void AppendStep(const StepRecord& step);
  const std::vector<StepRecord>& Steps() const { return steps_; }
  void Event(int64_t stamp_ns, const std::string& kind, const std::string& message);

  // Resume support: the rows an interrupted step (and any later one) left behind, so that the
  // re-run step does not count twice. Nothing is deleted: frames of steps >= first_step keep
  // their line and JPEG but get step_index -1 and step_name "superseded:<name>"; their rows of
  // observations.csv and of every measurement table with a step_index column move to
  // DIR/superseded/<table>. Each file is rewritten atomically. Returns the frames relabelled.
  int64_t SupersedeFrom(int first_step, int64_t stamp_ns);

  // Appends one row to a measurement table DIR/<name>, writing `header` first if the file is
  // new. Values are written as given (the caller formats them).
  void AppendRow(const std::string& name, const std::string& header, const std::vector<std::string>& row);

 private:
  DatasetWriter() = default;
  FILE* Open(const std::string& name, const std::string& header);
  void AppendLine(FILE* f, const std::string& name, const std::string& line);

  std::string dir_;
  nlohmann::json manifest_;
  int64_t next_frame_index_ = 0;
  int next_placement_index_ = 0;
  std::vector<PlacementRecord> placements_;
  std::vector<StepRecord> steps_;
  std::map<std::string, FILE*> files_;
};

// Header lines (without newline) of the dataset's own CSV files.
extern const char* const kFramesCsvHeader;
extern const char* const kPlacementsCsvHeader;
extern const char* const kStepsCsvHeader;

// Most frames a manifest may claim: a day at 30 fps is 2.6 million, so more is damage.
inline constexpr int64_t kMaxDatasetFrames = 100'000'000;

struct DatasetCheck {
  bool ok = false;                    // the dataset is usable (maybe after dropping a partial tail)
  int64_t num_frames = 0;             // complete, verified frames
  std::string status;                 // manifest status
  std::vector<std::string> errors;    // each names the file, line and field
  std::vector<std::string> warnings;  // partial last lines, orphan files, interrupted run
};

// Checks a dataset: manifest readable; frames.csv lines complete and consecutive from 0;
// each frame file present with the recorded size and CRC; a partial LAST line of any CSV and
// frame files with no line are tolerated (warnings: the last partial frame is dropped); the
// manifest's num_frames, when present, is at most kMaxDatasetFrames and matches frames.csv.
// verify_crc = false skips reading the JPEGs (size is still checked).
DatasetCheck CheckDataset(const std::string& dir, bool verify_crc = true);

// Makes a checked dataset clean: truncates partial last lines, removes orphan frame files
// and *.tmp files. Returns the check made before repairing; throws if it was not ok.
DatasetCheck RepairDataset(const std::string& dir);

// Reading for downstream stages. Throws std::runtime_error naming file:line:field.
nlohmann::json ReadManifest(const std::string& dir);
std::vector<FrameRecord> ReadFramesCsv(const std::string& dir);
std::vector<PlacementRecord> ReadPlacementsCsv(const std::string& dir);
std::vector<StepRecord> ReadStepsCsv(const std::string& dir);
// A table of DIR that DatasetWriter appends to (frames.csv, placements.csv, steps.csv and the
// measurement tables): every record ends with a line break, so a last record without one was
// cut short by a crash and is dropped (DroppedPartialTail()). A missing or empty file is a table
// with no header and no rows. Quoted cells may hold commas, quotes and line breaks.
calib::CsvTable ReadAppendedCsv(const std::string& path);
// Reads frame `frame_index`'s JPEG bytes.
std::vector<uint8_t> ReadFrameJpeg(const std::string& dir, int64_t frame_index);

}  // namespace owlcal::protocols
