// CSV fields for the evidence and measurement tables: RFC 4180 quoting, and no field a
// spreadsheet would run as a formula (issue 14: a marker label "=..." went in unescaped).
#include "forensics/csv_field.hpp"

#include <gtest/gtest.h>

namespace locard::forensics {
namespace {

TEST(CsvField, PlainTextStaysAsItIs) {
  EXPECT_EQ(csv_field("casing 3"), "casing 3");
  EXPECT_EQ(csv_field(""), "");
  EXPECT_EQ(csv_field("0.5 m"), "0.5 m");
}

TEST(CsvField, CommasQuotesAndLineBreaksAreQuoted) {
  EXPECT_EQ(csv_field("a,b"), "\"a,b\"");
  EXPECT_EQ(csv_field("say \"hi\""), "\"say \"\"hi\"\"\"");
  EXPECT_EQ(csv_field("two\nlines"), "\"two\nlines\"");
}

TEST(CsvField, FormulasBecomeText) {
  EXPECT_EQ(csv_field("=HYPERLINK(\"http://x\",\"y\")"), "\"'=HYPERLINK(\"\"http://x\"\",\"\"y\"\")\"");
  EXPECT_EQ(csv_field("+1"), "\"'+1\"");
  EXPECT_EQ(csv_field("-2+3"), "\"'-2+3\"");
  EXPECT_EQ(csv_field("@SUM(A1)"), "\"'@SUM(A1)\"");
  EXPECT_EQ(csv_field("\tcmd"), "\"'\tcmd\"");
  EXPECT_EQ(csv_field("a=b"), "a=b");  // only a leading sign starts a formula
}

}  // namespace
}  // namespace locard::forensics
