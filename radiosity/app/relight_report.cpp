// Phase 4 of `bin/radiosity relight` (relight_phases.hpp): the record and the printed summary.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "radiosity/app/relight_phases.hpp"
#include "radiosity/solve/multi_solve.hpp"

namespace radiosity::app {
namespace {

using namespace radiosity::relight;

nlohmann::json latency(const std::vector<double>& v) {
  return nlohmann::json{{"count", v.size()}, {"p50_ms", percentile(v, 50)}, {"p99_ms", percentile(v, 99)},
                        {"max_ms", v.empty() ? 0.0 : *std::max_element(v.begin(), v.end())}};
}

double fps(const ServedFrames& s) {
  double sum_ms = 0;
  for (double x : s.all_ms) sum_ms += x;
  return sum_ms > 0 ? 1e3 * double(s.all_ms.size()) / sum_ms : 0.0;
}

nlohmann::json or_null(bool given, const nlohmann::json& v) { return given ? v : nlohmann::json(); }

}  // namespace

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t k = size_t(std::ceil(p / 100 * double(v.size()))) - (p > 0 ? 1 : 0);
  return v[std::min(k, v.size() - 1)];
}

void relight_record(nlohmann::json& rec, const RelightArgs& a, const RelightInputs& in, const LightBasis& basis,
                    bool basis_loaded, const ServedFrames& s, double total_s) {
  const SolveConfig& cfg = a.cfg;
  rec["params"].update({{"frames", or_null(!a.frames.empty(), a.frames)},
                        {"random_frames", or_null(a.random_frames > 0, a.random_frames)},
                        {"seed", a.seed},
                        {"basis_file", or_null(!a.basis.empty(), a.basis)},
                        {"basis_tol", a.basis_tol},
                        {"method", to_string(cfg.method)},
                        {"backend", cfg.backend},
                        {"precision", to_string(cfg.precision)},
                        {"tol", cfg.tol},
                        {"max_iter", cfg.max_iter},
                        {"frame_budget_ms", or_null(a.frame_budget_ms > 0, a.frame_budget_ms)},
                        {"check_every", a.check_every},
                        {"threads", solver_threads(a.threads)}});
  nlohmann::json light_names = nlohmann::json::array();
  for (const NamedEntity& l : in.lights) light_names.push_back(l.name);
  rec["result"] = {{"frames", in.frames.size()},
                   {"lights", light_names},
                   {"mesh_hash", mesh_hash(in.m)},
                   {"basis", {{"loaded", basis_loaded}, {"iterations", basis.iterations},
                              {"max_residual", basis.max_residual}, {"tol", basis.tol}, {"seconds", basis.seconds}}},
                   {"latency", latency(s.all_ms)},
                   {"latency_basis", latency(s.basis_ms)},
                   {"latency_solved", latency(s.solved_ms)},
                   {"fps", fps(s)},
                   {"solved_frames", s.solved},
                   {"solved_over_tol", s.over_tol},
                   {"worst_solved_residual", or_null(s.solved > 0, s.worst_residual)},
                   {"checked_frames", s.checked},
                   {"worst_error", or_null(s.checked > 0, s.worst_error)},
                   {"per_frame", s.per_frame}};
  rec["times_s"] = {{"load", in.load_s}, {"ff_load", in.ff_load_s}, {"ff_build", in.ff_build_s},
                    {"basis", basis.seconds}, {"total", total_s}};
  rec["perf"] = {{"timer", "host wall clock; a basis frame is the mix alone (one thread), a solved frame its solve's setup and "
                           "iterations without the float64 residual check; rendering and checks excluded"}};
}

std::string storage_words(const RelightPlan& p, const RelightInputs& in) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "%s%s %s, %.1f MB", to_string(in.storage),
                !p.storage ? " (auto: the fewest bytes per product, sparse below half of dense's)" : "",
                to_string(p.values), in.frame_bytes / 1e6);
  return buf;
}

void print_relight_summary(const RelightArgs& a, const RelightPlan& p, const RelightInputs& in,
                           const LightBasis& basis, bool basis_loaded, const ServedFrames& s) {
  std::printf("relight: %s, %zu patches, %zu lights (%s), %zu frames\n", a.scene.c_str(), in.m.size(), in.lights.size(),
              name_list(in.lights).c_str(), in.frames.size());
  std::printf("  form factors: %s (the light basis's in float32)\n", storage_words(p, in).c_str());
  std::printf("  light basis: %s, %ld Jacobi steps to %.1e (largest residual %.2e), %.3f s\n",
              basis_loaded ? ("read from " + a.basis).c_str() : "solved", basis.iterations, basis.tol,
              basis.max_residual, basis.seconds);
  std::printf("  basis frames %zu: p50 %.4f ms, p99 %.4f ms; solved frames %zu: p50 %.3f ms, p99 %.3f ms; %.1f frames/s\n",
              s.basis_ms.size(), percentile(s.basis_ms, 50), percentile(s.basis_ms, 99), s.solved_ms.size(),
              percentile(s.solved_ms, 50), percentile(s.solved_ms, 99), fps(s));
  if (s.checked)
    std::printf("  worst error against a cold float64 solve over %ld checked frames: %.3e\n", s.checked, s.worst_error);
  if (!s.pngs.empty()) std::printf("  frames rendered: %s .. %s\n", s.pngs.front().c_str(), s.pngs.back().c_str());
}

}  // namespace radiosity::app
