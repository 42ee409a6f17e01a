// bin/poisson --list-backends [--json]: the table of backends (config.hpp) as the program states it, for people
// and for the Python that plans and reads runs (gpukit, analysis): names, GPU or not, built, what each runs, the
// vectors one plain CG iteration streams, and the default iteration limit.
#include <nlohmann/json.hpp>

#include <cstdio>
#include <string>

#include "poisson/config/config.hpp"

namespace poisson {

namespace {
template <class E>
nlohmann::json names(const std::vector<E>& v) {
  nlohmann::json a = nlohmann::json::array();
  for (E e : v) a.push_back(to_string(e));
  return a;
}
}  // namespace

nlohmann::json backends_json() {
  nlohmann::json list = nlohmann::json::array();
  for (const BackendEntry& b : backends()) {
    std::vector<Variant> variants{Variant::classic};
    if (b.onesweep) variants.push_back(Variant::onesweep);
    nlohmann::json vectors = {{"classic", b.vectors_classic}};
    if (b.onesweep) vectors["onesweep"] = b.vectors_onesweep;
    list.push_back({{"name", b.name()},
                    {"summary", b.summary},
                    {"gpu", b.gpu},
                    {"libraries", b.cublas ? nlohmann::json{"cublas"} : nlohmann::json::array()},
                    {"built", b.built},
                    {"why_not", b.why_not},
                    {"variants", names(variants)},
                    {"default_variant", {{"double", to_string(default_variant(b.id, Precision::double_))},
                                         {"float", to_string(default_variant(b.id, Precision::single))}}},
                    {"preconds", names(b.multigrid ? std::vector<Precond>{Precond::none, Precond::mg}
                                                   : std::vector<Precond>{Precond::none})},
                    {"methods", names(b.multigrid ? std::vector<Method>{Method::cg, Method::fmg}
                                                  : std::vector<Method>{Method::cg})},
                    {"vectors_per_iteration", vectors}});
  }
  return {{"program", "poisson"},
          {"backends", list},
          {"default_max_iter", {{"floor", kDefaultMaxIter.floor}, {"per_n", kDefaultMaxIter.per_n},
                                {"rule", "max(floor, per_n * N) with --tol, when --max-iter is not given"}}},
          {"vectors_per_iteration", "vectors of N^2 values one plain CG iteration streams (--precond none, "
                                    "--method cg; multigrid adds its levels', recorded as perf.vectors_per_iteration)"}};
}

std::string describe_backends(bool json) {
  const nlohmann::json j = backends_json();
  if (json) return j.dump(1) + "\n";
  std::string s = "backend  gpu  built  vectors/iteration        runs\n";
  for (const auto& b : j["backends"]) {
    std::string v, runs;
    for (const auto& [k, n] : b["vectors_per_iteration"].items()) v += (v.empty() ? "" : ", ") + k + " " + std::to_string(n.get<int>());
    runs = "variant " + b["variants"].dump() + ", precond " + b["preconds"].dump() + ", method " + b["methods"].dump();
    const std::string name = b["name"], built = b["built"] ? "yes" : "no";
    char line[400];
    std::snprintf(line, sizeof line, "%-8s %-4s %-6s %-24s %s\n", name.c_str(), b["gpu"] ? "yes" : "no", built.c_str(),
                  v.c_str(), runs.c_str());
    s += line;
  }
  s += "default --max-iter with --tol: max(" + std::to_string(kDefaultMaxIter.floor) + ", " +
       std::to_string(kDefaultMaxIter.per_n) + " N)\n";
  return s;
}

}  // namespace poisson
