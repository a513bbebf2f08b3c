#include "calib/trial_status.h"

namespace owlcal::calib {

const char* TrialStatusName(TrialStatus s) {
  switch (s) {
    case TrialStatus::kOk:
      return "ok";
    case TrialStatus::kNotSettled:
      return "not settled";
    case TrialStatus::kLostTarget:
      return "lost target";
    case TrialStatus::kOffTarget:
      return "off target";
    case TrialStatus::kTimedOut:
      return "timed out";
    case TrialStatus::kSkipped:
      return "skipped";
    case TrialStatus::kFailed:
      return "failed";
  }
  return "failed";
}

std::optional<TrialStatus> TrialStatusFromName(const std::string& name) {
  for (TrialStatus s : {TrialStatus::kOk,
                        TrialStatus::kNotSettled,
                        TrialStatus::kLostTarget,
                        TrialStatus::kOffTarget,
                        TrialStatus::kTimedOut,
                        TrialStatus::kSkipped,
                        TrialStatus::kFailed})
    if (name == TrialStatusName(s)) return s;
  return std::nullopt;
}

}  // namespace owlcal::calib
