#include "radiosity/solve/config/choices.hpp"

#include <algorithm>

#include "common/errors.hpp"

namespace radiosity {
namespace {

template <class E>
E parse_choice(const char* what, const std::string& name) {
  const std::vector<std::string>& names = choice_names<E>();
  const auto it = std::find(names.begin(), names.end(), name);
  if (it == names.end()) {
    std::string known;
    for (const std::string& n : names) known += (known.empty() ? "" : ", ") + n;
    throw hpcgi::UsageError(std::string("unknown ") + what + " '" + name + "' (known: " + known + ")");
  }
  return static_cast<E>(it - names.begin());
}

template <class E>
const std::string& name_of(E e) {
  return choice_names<E>().at(static_cast<size_t>(e));
}

}  // namespace

template <>
const std::vector<std::string>& choice_names<Method>() {
  static const std::vector<std::string> names = {"jacobi", "bicgstab", "gauss-seidel", "sor"};
  return names;
}
template <>
const std::vector<std::string>& choice_names<Layout>() {
  static const std::vector<std::string> names = {"aos", "soa"};
  return names;
}
template <>
const std::vector<std::string>& choice_names<Precision>() {
  static const std::vector<std::string> names = {"float", "double"};
  return names;
}
template <>
const std::vector<std::string>& choice_names<Start>() {
  static const std::vector<std::string> names = {"rrv", "zero", "emission"};
  return names;
}
template <>
const std::vector<std::string>& choice_names<Channels>() {
  static const std::vector<std::string> names = {"auto", "3"};
  return names;
}

Method parse_method(const std::string& name) { return parse_choice<Method>("method", name); }
Layout parse_layout(const std::string& name) { return parse_choice<Layout>("layout", name); }
Precision parse_precision(const std::string& name) { return parse_choice<Precision>("precision", name); }
Start parse_start(const std::string& name) { return parse_choice<Start>("start", name); }
Channels parse_channels(const std::string& name) { return parse_choice<Channels>("channels", name); }

const std::string& to_string(Method m) { return name_of(m); }
const std::string& to_string(Layout l) { return name_of(l); }
const std::string& to_string(Precision p) { return name_of(p); }
const std::string& to_string(Start s) { return name_of(s); }
const std::string& to_string(Channels c) { return name_of(c); }

std::string to_string(const StopRule& r) {
  return stop_rule_bases().at(static_cast<size_t>(r.base)) + (r.stacked ? "+stacked" : "") +
         (r.squared ? "+squared" : "");
}

}  // namespace radiosity
