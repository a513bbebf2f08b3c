// The report's first screen (reports/summary.h): the pan zero, which limits both pan maps'
// absolute angles, is a headline with its sigma.
#include "reports/summary.h"

#include <gtest/gtest.h>

namespace owlcal::reports {
namespace {

TEST(Summary, NamesThePanZeroWithItsSigma) {
  ReportData d;
  d.result.diagnostics["head"]["pan_zero"] = {{"sigma_deg", 0.8926}, {"factor", 1.25}, {"floor_deg", 0.8926}};
  const Summary s = MakeSummary(d);
  int found = 0;
  for (const Headline& h : s.headlines)
    if (h.quantity.find("pan zero") != std::string::npos) {
      ++found;
      EXPECT_EQ(h.unit, "deg");
      EXPECT_NE(h.value.find("0.89"), std::string::npos) << h.value;
      EXPECT_NE(h.note.find("both pan maps"), std::string::npos) << h.note;
    }
  EXPECT_EQ(found, 1);
}

TEST(Summary, NoPanZeroHeadlineWithoutAHeadFit) {
  const Summary s = MakeSummary(ReportData());
  for (const Headline& h : s.headlines) EXPECT_EQ(h.quantity.find("pan zero"), std::string::npos) << h.quantity;
}

}  // namespace
}  // namespace owlcal::reports
