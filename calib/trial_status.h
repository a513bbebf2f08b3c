#pragma once
// The outcome of one trial of a protocol (a fixation, a step-response trial, a limit probe, a
// saccade), as every dataset table records it and every evaluation reads it: a status from a
// fixed vocabulary plus a free-text reason. Nothing a protocol tried is dropped: a trial that
// failed is a row with its status, counted as "n ok of N" and named in the report.
//
//   ok            the trial did what it should (fixation settled on the target, ...)
//   not settled   the loop ran out of frames, oscillated or stopped before a limit
//   lost target   the target left the image (or was never found) for too many frames
//   off target    the loop settled, but not on the target (its appearance or the two eyes'
//                 rays say so): never ranged
//   timed out     the robot or the stream did not answer in time
//   skipped       not run, for the reason given (e.g. the fixation before it failed)
//   failed        the measurement could not be made (e.g. the camera shows no motion)
#include <optional>
#include <string>

namespace owlcal::calib {

enum class TrialStatus { kOk, kNotSettled, kLostTarget, kOffTarget, kTimedOut, kSkipped, kFailed };

// "ok", "not settled", "lost target", "off target", "timed out", "skipped", "failed".
const char* TrialStatusName(TrialStatus status);
// The names above; nullopt for anything else.
std::optional<TrialStatus> TrialStatusFromName(const std::string& name);

}  // namespace owlcal::calib
