#pragma once
// Tables of the vergence-log fit (fitting/vergence_log_fit.h) for the lab report:
//   VergenceReportMarkdown  parameters with sigma, notes, the five rows that dominate chi2 and
//                           the leave-one-out range error (against the robot's fixed constants
//                           when the leave-one-out had them)
//   VergenceRowsCsv         row,run,true_cm,Rx_us,Lx_us,fixed_cm,loo_cm,fit_cm,res_rx,res_lx,chi2,
//                           cm_per_us (one line per log row)
#include <string>
#include <vector>

#include "fitting/vergence_log_fit.h"

namespace owlcal::reports {

std::string VergenceReportMarkdown(const std::vector<fitting::VergenceLogRow>& rows,
                                   const fitting::VergenceLogFit& fit,
                                   const fitting::LooSummary& loo);
std::string VergenceRowsCsv(const std::vector<fitting::VergenceLogRow>& rows,
                            const fitting::VergenceLogFit& fit,
                            const fitting::LooSummary& loo);

}  // namespace owlcal::reports
