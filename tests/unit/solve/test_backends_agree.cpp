// The backends and layouts against one another: the same method on the same system must give the same B.
#include <gtest/gtest.h>

#include <string>

#include "radiosity/solve/solve.hpp"
#include "configs.hpp"
#include "reference.hpp"

using namespace radiosity;
using namespace solve_test;

namespace {

SolveResult run(const System& s, const std::string& backend, const std::string& layout, const std::string& method,
                const std::string& precision, long steps, int threads = 2) {
  SolveConfig c = solve_config(backend, layout, method, precision, steps, threads);
  c.tol = precision == "float" ? 1e-5 : 1e-10;
  return solve(s, c);
}

}  // namespace

TEST(BackendsAgree, AosAndSoaInFloat) {
  const Problem p = random_problem(200, 21);
  for (const char* backend : {"serial", "openmp"}) {
    SCOPED_TRACE(backend);
    EXPECT_LE(rel_diff(run(p.sys, backend, "aos", "jacobi", "float", 32).B,
                       run(p.sys, backend, "soa", "jacobi", "float", 32).B), 1e-6);
    EXPECT_LE(rel_diff(run(p.sys, backend, "aos", "jacobi", "float", 0).B,
                       run(p.sys, backend, "soa", "jacobi", "float", 0).B), 1e-6);
    EXPECT_LE(rel_diff(run(p.sys, backend, "aos", "bicgstab", "float", 0).B,
                       run(p.sys, backend, "soa", "bicgstab", "float", 0).B), 1e-6);
  }
}

// A thread owns whole rows of the product, so fixed-step Jacobi is bit for bit the same with any thread count;
// BiCG-STAB's dots add per-thread partial sums, which moves the last bits only. 3 and 5 threads on n = 203 give
// blocks that are not all alike, and one thread more than rows blocks would need for n = 40.
TEST(BackendsAgree, OpenmpAndSerial) {
  for (size_t n : {203, 40}) {
    const Problem p = random_problem(n, 23);
    for (const char* layout : {"aos", "soa"})
      for (const char* precision : {"float", "double"}) {
        SCOPED_TRACE(std::string(layout) + " " + precision + " n " + std::to_string(n));
        const SolveResult serial = run(p.sys, "serial", layout, "jacobi", precision, 32);
        for (int threads : {2, 3, 5}) EXPECT_EQ(run(p.sys, "openmp", layout, "jacobi", precision, 32, threads).B, serial.B);
        const double tol = std::string(precision) == "float" ? 1e-6 : 1e-12;
        EXPECT_LE(rel_diff(run(p.sys, "openmp", layout, "bicgstab", precision, 0, 3).B,
                           run(p.sys, "serial", layout, "bicgstab", precision, 0).B), tol);
      }
  }
}

// RRV's loop and the dense kernels do the same arithmetic in float, summed in another order.
TEST(BackendsAgree, OriginalEqualsSerialJacobiWithTheSameSteps) {
  const Problem p = random_problem(150, 31);
  for (long steps : {1, 8, 32}) {
    SCOPED_TRACE(steps);
    const SolveResult orig = run(p.sys, "original", "aos", "jacobi", "float", steps);
    const SolveResult dense = run(p.sys, "serial", "aos", "jacobi", "float", steps);
    EXPECT_EQ(orig.status, SolveStatus::steps_done);
    EXPECT_EQ(orig.iterations, steps);
    EXPECT_LE(rel_diff(orig.B, dense.B), 1e-6);
  }
}

// RRV keeps only F_ij > threshold: the same as the dense solve of F with the others set to 0.
TEST(BackendsAgree, OriginalDropsFormFactorsAtOrBelowTheThreshold) {
  Problem p = random_problem(100, 37);
  const float threshold = p.F[1];  // a value that is present, so "at" the threshold is exercised too
  SolveConfig c;
  c.backend = "original";
  c.precision = Precision::single;
  c.steps = 16;
  c.ff_threshold = threshold;
  const SolveResult orig = solve(p.sys, c);
  size_t kept = 0;
  for (float& f : p.F) {
    if (f <= threshold) f = 0;
    kept += f > 0;
  }
  EXPECT_EQ(orig.matrix_bytes, 16.0 * double(kept));  // one (pointer, float) pair, padded to 16 bytes
  EXPECT_LE(rel_diff(orig.B, run(p.sys, "serial", "aos", "jacobi", "float", 16).B), 1e-6);
}
