// bin/radiosity --list-backends [--json]: the solver's registry (radiosity/solve/solve.hpp solve_backends) as the
// program states it, for people and for the Python that plans and reads runs (gpukit, analysis).
#include <nlohmann/json.hpp>

#include <cstdio>
#include <string>

#include "radiosity/app/commands.hpp"

namespace radiosity::app {

namespace {
template <class E>
nlohmann::json names(const std::vector<E>& v) {
  nlohmann::json a = nlohmann::json::array();
  for (E e : v) a.push_back(to_string(e));
  return a;
}

// The CUDA libraries a backend calls (in some configuration: cuSPARSE for csr float32 F only).
nlohmann::json libraries(const SolveBackend& b) {
  nlohmann::json a = nlohmann::json::array();
  if (b.cublas) a.push_back("cublas");
  if (b.cusparse) a.push_back("cusparse");
  return a;
}
}  // namespace

std::string describe_backends(bool json) {
  nlohmann::json list = nlohmann::json::array();
  for (const SolveBackend& b : solve_backends())
    list.push_back({{"name", b.name},
                    {"summary", b.summary},
                    {"gpu", b.gpu},
                    {"libraries", libraries(b)},
                    {"built", b.built},
                    {"why_not", b.why_not},
                    {"methods", names(b.methods)},
                    {"layouts", names(b.layouts)},
                    {"precisions", names(b.precisions)},
                    {"tolerance", b.tolerance},
                    {"distributed", b.distributed}});
  const nlohmann::json j = {{"program", "radiosity"}, {"backends", list}, {"default_max_iter", SolveConfig{}.max_iter}};
  if (json) return j.dump(1) + "\n";
  std::string s = "backend   gpu  built  methods                               layouts   precisions\n";
  for (const SolveBackend& b : solve_backends()) {
    char line[300];
    std::snprintf(line, sizeof line, "%-9s %-4s %-6s %-37s %-9s %s\n", b.name.c_str(), b.gpu ? "yes" : "no",
                  b.built ? "yes" : "no", joined_names(b.methods).c_str(), joined_names(b.layouts).c_str(),
                  joined_names(b.precisions).c_str());
    s += line;
  }
  return s + "default --max-iter with --tol: " + std::to_string(SolveConfig{}.max_iter) + "\n";
}

}  // namespace radiosity::app
