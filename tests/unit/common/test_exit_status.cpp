// run_main turns the project's exceptions into the exit statuses every program shares (common/errors.hpp) and
// one line on stderr; the numerical guards of both programs rely on it for exit status 3.
#include <gtest/gtest.h>

#include <cstdint>
#include <stdexcept>
#include <string>

#include "common/cli.hpp"
#include "common/errors.hpp"
#include "common/memory.hpp"

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
  EXPECT_EQ(status_of([]() -> int { throw hpcgi::NotConvergedError("residual 0.5 after 10 iterations"); }, err), 4);
  EXPECT_EQ(err, "prog: not converged: residual 0.5 after 10 iterations\n");
  EXPECT_EQ(status_of([]() -> int { throw hpcgi::DisagreedError("difference 1e-3"); }, err), 5);
  EXPECT_EQ(err, "prog: disagreed with its float64 check: difference 1e-3\n");
  EXPECT_EQ(status_of([]() -> int { throw std::runtime_error("disk full"); }, err), 1);
  EXPECT_EQ(err, "prog: error: disk full\n");
}

TEST(ByteSizes, UnitsAreBinary) {
  EXPECT_EQ(hpcgi::parse_bytes("67108864"), 67108864.0);
  EXPECT_EQ(hpcgi::parse_bytes("64M"), 64.0 * 1024 * 1024);
  EXPECT_EQ(hpcgi::parse_bytes("64MiB"), 64.0 * 1024 * 1024);
  EXPECT_EQ(hpcgi::parse_bytes("64MB"), 64.0 * 1024 * 1024);
  EXPECT_EQ(hpcgi::parse_bytes("1.5G"), 1.5 * 1024 * 1024 * 1024);
  EXPECT_EQ(hpcgi::parse_bytes("2k"), 2048.0);
  for (const char* bad : {"", "M", "64X", "64 M", "-1G", "0", "nan", "inf", "64MM", "64iB"})
    EXPECT_THROW(hpcgi::parse_bytes(bad), hpcgi::UsageError) << bad;
  EXPECT_EQ(hpcgi::format_bytes(64.0 * 1024 * 1024), "64.0 MiB");
}

TEST(ExitStatus, AnAgreedErrorKeepsItsStatus) {
  std::string err;
  EXPECT_EQ(status_of([]() -> int { throw hpcgi::Agreed<hpcgi::UsageError>("too big"); }, err), 2);
  EXPECT_EQ(err, "prog: too big\n");
  EXPECT_EQ(status_of([]() -> int { throw hpcgi::Agreed<hpcgi::NumericalError>("nonfinite"); }, err), 3);
}

// finish(outcome) ends a run that is no answer with its status; an answer goes on.
TEST(ExitStatus, FinishThrowsTheOutcomesStatus) {
  std::string err;
  EXPECT_EQ(status_of([] { hpcgi::finish({}); return 0; }, err), 0);
  for (int s : {hpcgi::kExitNumerical, hpcgi::kExitNotConverged, hpcgi::kExitDisagreed})
    for (bool agreed : {false, true}) {
      EXPECT_EQ(status_of([&] { hpcgi::finish({s, "why"}, agreed); return 0; }, err), s);
      EXPECT_NE(err.find("why"), std::string::npos) << err;
    }
  EXPECT_THROW(hpcgi::finish({hpcgi::kExitUsage, "no"}), std::logic_error);
}

// common/memory's huge_array: 2 MiB-aligned, zero, writable to its last value, with or without huge pages asked for.
TEST(HugeArray, AlignedZeroAndWritable) {
  for (const size_t n : {size_t(1), size_t(1000), size_t(3) << 20}) {
    hpcgi::HugeArray<double> a = hpcgi::huge_array<double>(n);
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(a.get()) % (std::uintptr_t(2) << 20), 0u) << n;
    EXPECT_EQ(a[0], 0.0);
    EXPECT_EQ(a[n - 1], 0.0);
    a[n - 1] = 1.5;
    EXPECT_EQ(a[n - 1], 1.5);
  }
}
