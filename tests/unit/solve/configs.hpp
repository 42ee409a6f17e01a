// The one way the solve tests build a SolveConfig: the choices by the names bin/radiosity's options take, parsed as
// the options parse them (radiosity/solve/choices.hpp), two threads, and the tolerance each working precision can
// reach (float 1e-6, double 1e-12) unless steps are fixed. A test sets what else it varies on the result.
#pragma once
#include <string>

#include "radiosity/solve/solve.hpp"

namespace solve_test {

inline radiosity::SolveConfig solve_config(const std::string& backend, const std::string& layout,
                                           const std::string& method, const std::string& precision, long steps = 0,
                                           int threads = 2) {
  radiosity::SolveConfig c;
  c.backend = backend;
  c.layout = parse_layout(radiosity::parse_layout(layout));
  c.method = parse_method(radiosity::parse_method(method));
  c.precision = parse_precision(radiosity::parse_precision(precision));
  c.steps = steps;
  c.tol = precision == "float" ? 1e-6 : 1e-12;
  c.threads = threads;
  return c;
}

}  // namespace solve_test
