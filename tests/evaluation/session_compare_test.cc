#include "evaluation/session_compare.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "reports/session_tables.h"

namespace owlcal::evaluation {
namespace session_compare_test {

fitting::Parameter Param(const std::string& name, double value, double sigma, const std::string& unit) {
  fitting::Parameter p;
  p.name = name;
  p.value = value;
  p.sigma = sigma;
  p.unit = unit;
  p.determined = std::isfinite(sigma);
  return p;
}

fitting::CalibrationResult Make(double fx, double fx_sigma, double base, double base_sigma) {
  fitting::CalibrationResult r;
  r.Set(Param("left.fx", fx, fx_sigma, "px"));
  r.Set(Param("stereo.baseline_mm", base, base_sigma, "mm"));
  r.Set(Param("left.k3", 0.1, std::numeric_limits<double>::quiet_NaN(), ""));
  return r;
}

TEST(SessionCompare, DifferencesInSigmaUnitsFlagOnlyRealChanges) {
  const auto c = CompareSessions(
      {{"s1", Make(590, 1.0, 63.5, 0.1)}, {"s2", Make(591, 1.0, 64.5, 0.1)}, {"s3", Make(590.5, 0.5, 63.6, 0.2)}});
  ASSERT_EQ(c.parameters.size(), 3u);
  ASSERT_EQ(c.pairs.size(), 3u);
  // s1 -> s2: fx 1 px over sqrt(2) px: noise; baseline 1 mm over 0.141 mm: changed.
  EXPECT_NEAR(c.pairs[0].z[0], 1 / std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(c.pairs[0].z[1], 1 / std::hypot(0.1, 0.1), 1e-9);
  EXPECT_TRUE(std::isnan(c.pairs[0].z[2])) << "k3 has no sigma: no verdict";
  ASSERT_EQ(c.changed.size(), 2u);  // baseline s1->s2 and s2->s3; s1->s3 is 0.45 sigma
  EXPECT_NE(c.changed[0].find("stereo.baseline_mm: s1 -> s2"), std::string::npos) << c.changed[0];
  const std::string md = reports::SessionComparisonMarkdown(c);
  EXPECT_NE(md.find("**changed**"), std::string::npos);
  EXPECT_NE(md.find("no sigma"), std::string::npos);
  EXPECT_NE(reports::SessionComparisonCsv(c).find("s2-s1"), std::string::npos);
}

}  // namespace session_compare_test
}  // namespace owlcal::evaluation
