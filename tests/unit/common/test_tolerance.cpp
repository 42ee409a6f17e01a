// check_tolerance refuses a tolerance below what the precision's rounding can reach, and its advice names a value
// it then accepts (issue 54: "use --tol 1e-09 or more" named the value just refused in float).
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "common/cli.hpp"
#include "common/errors.hpp"

namespace {

std::string refusal(double tol, const std::string& precision) {
  try {
    hpcgi::check_tolerance(tol, precision);
  } catch (const hpcgi::UsageError& e) {
    return e.what();
  }
  return "";
}

// The value after "use --tol " in the refusal.
double advised(const std::string& why) {
  const size_t at = why.find("use --tol ");
  EXPECT_NE(at, std::string::npos) << why;
  return std::strtod(why.c_str() + at + 10, nullptr);
}

}  // namespace

TEST(Tolerance, TheAdviceIsAcceptedInEveryPrecision) {
  for (const std::string precision : {"float", "double"}) {
    const double floor = precision == "float" ? 1.1920928955078125e-9 : 2.220446049250313e-18;
    for (double tol : {floor * 0.999, floor / 10, 1e-30}) {
      const std::string why = refusal(tol, precision);
      ASSERT_FALSE(why.empty()) << precision << " " << tol;
      const double a = advised(why);
      EXPECT_GE(a, floor) << why;
      EXPECT_EQ(refusal(a, precision), "") << why;  // the advised value is accepted
      EXPECT_LT(a, 10 * floor) << why;              // and is no far cry from the floor
    }
  }
  EXPECT_NE(refusal(1e-9, "float").find("use --tol 2e-09 or more, or --precision double"), std::string::npos)
      << refusal(1e-9, "float");
  EXPECT_EQ(refusal(1e-9, "double"), "");
}
