// The choices of a SolveConfig (solve.hpp) as enums, each with its names: parsed once where a program reads them
// (bin/radiosity's options), printed and recorded by the same names (to_string), so that the records and the tables
// built from them keep the strings they always had. The backend is no enum: it is a name from the registry
// (solve_backends()); the stopping rule is a StopRule (stop_rule.hpp).
#pragma once
#include <string>
#include <vector>

#include "radiosity/solve/config/stop_rule.hpp"

namespace radiosity {

enum class Method { jacobi, bicgstab, gauss_seidel, sor };  // jacobi | bicgstab | gauss-seidel | sor
enum class Layout { aos, soa };                              // aos | soa
enum class Precision { single, double_ };                    // float | double: the working precision
enum class Start { rrv, zero, emission };                    // b_0: rrv | zero | emission
enum class Channels { automatic, three };                    // auto | 3

// Each choice's names in the enum's order, as the options, the records and the errors spell them.
template <class E>
const std::vector<std::string>& choice_names();
template <>
const std::vector<std::string>& choice_names<Method>();
template <>
const std::vector<std::string>& choice_names<Layout>();
template <>
const std::vector<std::string>& choice_names<Precision>();
template <>
const std::vector<std::string>& choice_names<Start>();
template <>
const std::vector<std::string>& choice_names<Channels>();

// Throw hpcgi::UsageError "unknown method 'x' (known: jacobi, bicgstab, gauss-seidel, sor)" for a name not listed.
Method parse_method(const std::string& name);
Layout parse_layout(const std::string& name);
Precision parse_precision(const std::string& name);
Start parse_start(const std::string& name);
Channels parse_channels(const std::string& name);

const std::string& to_string(Method m);
const std::string& to_string(Layout l);
const std::string& to_string(Precision p);
const std::string& to_string(Start s);
const std::string& to_string(Channels c);
// BASE[+stacked][+squared], which parse_stop_rule reads back.
std::string to_string(const StopRule& r);

// The names of some choices, joined by `sep` (the registry's lists in its errors, --help).
template <class E>
std::string joined_names(const std::vector<E>& choices, const std::string& sep = ", ") {
  std::string s;
  for (E e : choices) s += (s.empty() ? "" : sep) + to_string(e);
  return s;
}

}  // namespace radiosity
