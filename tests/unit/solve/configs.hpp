// The one way the solve tests build a SolveConfig: the choices by the names bin/radiosity's options take, parsed as
// the options parse them (radiosity/solve/config/choices.hpp), two threads, and the tolerance each working precision can
// reach (float 1e-6, double 1e-12) unless steps are fixed. A test sets what else it varies on the result.
#pragma once
#include <gtest/gtest.h>

#include <string>

#include "radiosity/solve/solve.hpp"
#include "reference.hpp"

namespace solve_test {

inline radiosity::SolveConfig solve_config(const std::string& backend, const std::string& layout,
                                           const std::string& method, const std::string& precision, long steps = 0,
                                           int threads = 2) {
  radiosity::SolveConfig c;
  c.backend = backend;
  c.layout = radiosity::parse_layout(layout);
  c.method = radiosity::parse_method(method);
  c.precision = radiosity::parse_precision(precision);
  c.steps = steps;
  c.tol = precision == "float" ? 1e-6 : 1e-12;
  c.threads = threads;
  return c;
}

// The same configuration on F dense and on F in another storage (`stored`, whose matrix is `stored_bytes`): the
// same status, B within 1e-6 relative (the values are the same; the sums' order may differ), the stored bytes read.
inline void expect_storage_agrees(const radiosity::System& dense, const radiosity::System& stored,
                                  const radiosity::SolveConfig& c, double stored_bytes) {
  const radiosity::SolveResult want = radiosity::solve(dense, c), got = radiosity::solve(stored, c);
  EXPECT_EQ(got.status, want.status);
  EXPECT_LE(rel_diff(got.B, want.B), 1e-6);
  EXPECT_EQ(got.matrix_bytes, stored_bytes);
}

}  // namespace solve_test
