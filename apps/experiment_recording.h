#pragma once
// The eye-movement experiment commands (vor, main-sequence, catch-up) share one way to get their
// dataset: record the experiment's protocol on the robot (the virtual Owl by default), the eyes
// on calibrate's fitted maps (--calib) or on the robot file's nominal ones, unless --dataset
// names a recording to evaluate instead.
#include <optional>
#include <string>

#include "apps/robot_options.h"
#include "protocols/protocol.h"

namespace owlcal::apps {

struct ExperimentRecording {
  std::string command;       // "vor": names the command in messages
  std::string protocol;      // protocol name (protocols/standard) or file
  std::string dataset_name;  // recorded into OUT/datasets/<dataset_name>
  std::string nominal_note;  // printed when there is no --calib ("the eyes move on ... NOMINAL maps")
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

}  // namespace owlcal::apps
