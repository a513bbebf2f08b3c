#pragma once
// Tables of owlcal fit-toe-in (fitting/toe_in_servo_fit.h):
//   ToeInMarkdown  the sets (PWM, relative yaw, fitted, residual, verdict), the fitted scales with
//                  sigma, chi2/dof and the comparison with the guide's 0.113 deg/us, the notes
//   ToeInSetsCsv   name,Rx,Ry,Lx,Ly,ok,yaw_deg,yaw_sigma_deg,pitch_deg,roll_deg,predicted_deg,
//                  residual_deg,z,verdict,message
#include <string>
#include <vector>

#include "fitting/toe_in_servo_fit.h"

namespace owlcal::reports {

std::string ToeInMarkdown(const std::vector<fitting::ToeInSet>& sets, const fitting::ToeInServoFit& fit);
std::string ToeInSetsCsv(const std::vector<fitting::ToeInSet>& sets, const fitting::ToeInServoFit& fit);

}  // namespace owlcal::reports
