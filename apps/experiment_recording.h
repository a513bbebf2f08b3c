#pragma once
// The experiment commands (vor, main-sequence, catch-up, track, sharpness) are rows of one table
// (ExperimentCommand, RegisterExperiment): the same options and one way to get their dataset:
// record the experiment's protocol on the robot (the virtual Owl by default), the eyes on
// calibrate's fitted maps (--calib) or on the robot file's nominal ones, unless --dataset names a
// recording to evaluate instead. Each row adds only its evaluation: the study, its page, the
// summary it prints and its exit code.
#include <functional>
#include <optional>
#include <string>

#include "apps/robot_options.h"
#include "protocols/protocol.h"

namespace owlcal::apps {

struct ExperimentRecording {
  std::string command;       // "vor": names the command in messages
  std::string protocol;      // protocol name (protocols/standard) or file
  std::string dataset_name;  // recorded into OUT/datasets/<dataset_name>
  // Printed when there is no --calib ("the eyes move on ... NOMINAL maps"); empty: the experiment
  // moves no eye on the maps (no --calib, no --tracker).
  std::string nominal_note;
  RobotOptions robot;
  std::string out, dataset, calib;
  bool quiet = false;
  // --tracker: "" = as the protocol's steps say; "disc" (the fixation disc detector) or "lk"
  // (Lucas-Kanade seeded by it) for every step that locates the target (`locator:`).
  std::string tracker;
};

// Adds --tracker (lk|disc) to an experiment command.
void AddTrackerOption(CLI::App* cmd, std::string* tracker);
// Sets every locating step's locator (`locator:` of saccade, vor, main-sequence, catch-up, fixate,
// step-response) to kind; returns how many steps it set.
int SetProtocolLocator(protocols::Protocol* p, protocols::Locator kind);

// The dataset to evaluate: --dataset as given, or the new recording's folder. nullopt when the
// recording did not complete (the reason and how to evaluate what was recorded are on stderr).
// Throws UsageError for --dataset together with --calib, or --tracker with --dataset.
std::optional<std::string> RecordOrUseDataset(const ExperimentRecording& e);

// What an experiment's evaluation gets: the dataset to evaluate (recorded or --dataset), or with
// --images the image list instead (dataset empty).
struct ExperimentInput {
  std::string dataset;
  std::string images;
  std::string out;
  bool figures = true;
};

// One experiment command: `owlcal <name>` with --out, --dataset, --protocol, --no-figures, --quiet
// and the robot options; --calib and --tracker when nominal_note is set; --images when
// images_help is set (then --protocol is not offered).
struct ExperimentCommand {
  std::string name;          // the command: "catch-up"
  std::string help;          // `owlcal <name> --help`
  std::string protocol;      // the standard protocol it records: "catch_up"
  std::string nominal_note;  // ExperimentRecording::nominal_note
  std::string images_help;   // --images: evaluate image pairs listed in a CSV instead
  // Evaluates, writes the report and prints the summary; returns the exit code.
  std::function<int(const ExperimentInput&)> evaluate;
};

// Registers `owlcal <c.name>` (apps/command_registry.h); true.
bool RegisterExperiment(ExperimentCommand c);

}  // namespace owlcal::apps
