#include "io/strict_number.h"

#include <gtest/gtest.h>

namespace owlcal::io {
namespace {

TEST(StrictNumber, AcceptsPlainDecimalNumbers) {
  for (const auto& [text, value] : std::vector<std::pair<const char*, double>>{
           {"0", 0}, {"-12", -12}, {"+2.5", 2.5}, {".5", 0.5}, {"5.", 5}, {"1e-3", 1e-3}, {"-2E+4", -2e4}}) {
    const auto v = ParseFiniteDouble(text);
    ASSERT_TRUE(v.has_value()) << text;
    EXPECT_DOUBLE_EQ(*v, value) << text;
  }
}

TEST(StrictNumber, RejectsNanInfHexSpacesAndTrailingText) {
  for (const char* text :
       {"",  " ", "nan", "NaN", "-nan", "inf", "-inf", "infinity", ".inf",   ".nan", "0x10", "0X1p3", "1e",  "e5",
        ".", "-", "+",   " 1",  "1 ",   "4x0", "1,5",  "1e999",    "-1e400", "1..2", "--1",  "1e+",   "\x01"}) {
    EXPECT_FALSE(ParseFiniteDouble(text).has_value()) << "'" << text << "'";
  }
}

TEST(StrictNumber, IntegersRejectFractionsHexAndOverflow) {
  EXPECT_EQ(ParseInteger("-42"), -42);
  EXPECT_EQ(ParseInteger("+7"), 7);
  EXPECT_EQ(ParseInteger("9223372036854775807"), INT64_MAX);
  for (const char* text : {"", "1.0", "1e3", "0x600", "9223372036854775808", " 5", "5 ", "-", "+", "12a"}) {
    EXPECT_FALSE(ParseInteger(text).has_value()) << "'" << text << "'";
  }
}

TEST(StrictNumber, CheckNamesTheValueAndTheRange) {
  double d = -1;
  EXPECT_EQ(CheckNumber("1e300", 0, 1e4, &d), "= 1e+300 is outside [0, 10000]");
  EXPECT_EQ(d, -1);
  EXPECT_EQ(CheckNumber("nan", 0, 1e4, &d), "= 'nan' is not a finite decimal number");
  EXPECT_EQ(CheckNumber("12.5", 0, 1e4, &d), "");
  EXPECT_EQ(d, 12.5);
  int i = 0;
  EXPECT_EQ(CheckInt("2147483647", 1, 10000, &i), "= 2147483647 is outside [1, 10000]");
  EXPECT_EQ(CheckInt("99999999999999999999", 1, 10000, &i), "= '99999999999999999999' is not an integer");
  EXPECT_EQ(CheckInt("25", 1, 10000, &i), "");
  EXPECT_EQ(i, 25);
}

TEST(StrictNumber, PrintableHidesControlBytesAndCutsLongText) {
  EXPECT_EQ(Printable("ok\x1b[2J\xff"), "ok?[2J?");
  EXPECT_EQ(Printable(std::string(100, 'a')), std::string(40, 'a') + "...");
}

}  // namespace
}  // namespace owlcal::io
