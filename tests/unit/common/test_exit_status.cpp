// run_main turns the project's exceptions into the exit statuses every program shares (common/errors.hpp) and
// one line on stderr; the numerical guards of both programs rely on it for exit status 3.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "common/cli.hpp"
#include "common/errors.hpp"

namespace {

int status_of(const std::function<int()>& body, std::string& err) {
  testing::internal::CaptureStderr();
  const int code = hpcgi::run_main("prog", body);
  err = testing::internal::GetCapturedStderr();
  return code;
}

}  // namespace

TEST(ExitStatus, EachErrorHasItsStatusAndOneLine) {
  std::string err;
  EXPECT_EQ(status_of([] { return 0; }, err), hpcgi::kExitOk);
  EXPECT_EQ(err, "");
  EXPECT_EQ(status_of([]() -> int { throw hpcgi::UsageError("bad --n"); }, err), 2);
  EXPECT_EQ(err, "prog: bad --n\n");
  EXPECT_EQ(status_of([]() -> int { throw hpcgi::NumericalError("breakdown: p·Ap = 0"); }, err), 3);
  EXPECT_EQ(err, "prog: numerical failure: breakdown: p·Ap = 0\n");
  EXPECT_EQ(status_of([]() -> int { throw std::runtime_error("disk full"); }, err), 1);
  EXPECT_EQ(err, "prog: error: disk full\n");
}
