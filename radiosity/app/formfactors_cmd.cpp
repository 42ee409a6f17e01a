// `bin/radiosity formfactors`: the hemicube once, into a form-factor file named for the mesh (report §3.6).
#include <omp.h>

#include <cstdio>
#include <filesystem>
#include <iostream>

#include "common/memory.hpp"
#include "common/record.hpp"
#include "common/timer.hpp"
#include "radiosity/app/commands.hpp"
#include "radiosity/formfactor/diagnostics.hpp"
#include "radiosity/formfactor/ff_file.hpp"
#include "radiosity/formfactor/hemicube.hpp"

namespace radiosity::app {

void add_formfactors(CLI::App& app, FormFactorArgs& a) {
  CLI::App* cmd = app.add_subcommand("formfactors", "compute the form factors of a scene by the hemicube into a file");
  add_scene_options(cmd, a);
  cmd->add_option("-o,--out", a.out, "form-factor file to write")->required();
  cmd->add_option("--hemicube", a.hemicube.resolution, "hemicube resolution R (top face R x R)")
      ->capture_default_str();
  cmd->add_option("--weights", a.weights, "exact (Cohen-Greenberg delta form factors) or rrv2007 (RRV's cos*cos)")
      ->check(CLI::IsMember({"exact", "rrv2007"}))->capture_default_str();
  cmd->add_option("--threshold", a.hemicube.threshold, "store form factors <= T as 0 (RRV's threshold)")
      ->capture_default_str();
}

int run_formfactors(const FormFactorArgs& a) {
  hpcgi::Timer total;
  HemicubeParams hp = a.hemicube;
  hp.weights = parse_hemicube_weights(a.weights);
  validate(hp);
  double load_s = 0;
  const Mesh m = load_scene(a, &load_s);
  const double n = static_cast<double>(m.size());
  hpcgi::require_host_memory("the form factors of " + std::to_string(m.size()) + " patches", 4.0 * n * n);

  hpcgi::Timer t;
  const FormFactors ff = compute_form_factors(m, hp, a.quiet ? HemicubeProgress{} : stderr_progress());
  const double compute_s = t.seconds();
  t.reset();
  const FormFactorDiagnostics d = diagnose_form_factors(m, ff);
  const double diag_s = t.seconds();
  t.reset();
  save_form_factors(a.out, m, ff);
  const double save_s = t.seconds();
  size_t nonzero = 0;
  for (float v : ff.values) nonzero += v != 0.0f;

  nlohmann::json rec = hpcgi::record::make("radiosity");
  rec["params"] = {{"command", "formfactors"}, {"scene", a.scene},          {"divide", a.load.divide},
                   {"patches", m.size()},      {"hemicube", hp.resolution}, {"weights", a.weights},
                   {"threshold", hp.threshold}, {"threads", omp_get_max_threads()}};
  rec["result"] = {{"min_row_sum", d.min_row_sum},
                   {"max_row_sum", d.max_row_sum},
                   {"max_reciprocity_error", d.max_reciprocity_error},
                   {"mean_reciprocity_error", d.mean_reciprocity_error},
                   {"reciprocity_pairs", d.pairs_compared},
                   {"nonzero_fraction", static_cast<double>(nonzero) / (n * n)},
                   {"mesh_hash", mesh_hash(m)},
                   {"file", a.out},
                   {"file_bytes", std::filesystem::file_size(a.out)}};
  rec["times_s"] = {{"load", load_s},
                    {"hemicube", compute_s},
                    {"diagnostics", diag_s},
                    {"save", save_s},
                    {"total", total.seconds()}};
  rec["perf"] = {{"patches_per_s", n / compute_s}};
  if (!a.quiet) {
    std::printf("formfactors: %s, %zu patches (divide %g), hemicube R=%d %s weights, threshold %g, %d threads\n",
                a.scene.c_str(), m.size(), a.load.divide, hp.resolution, a.weights.c_str(), hp.threshold,
                omp_get_max_threads());
    std::printf("  row sums %.4f .. %.4f; reciprocity error max %.3g, mean %.3g over %zu pairs; %.1f%% non-zero\n",
                d.min_row_sum, d.max_row_sum, d.max_reciprocity_error, d.mean_reciprocity_error, d.pairs_compared,
                100.0 * static_cast<double>(nonzero) / (n * n));
    std::printf("  time: load %.3f s, hemicube %.3f s (%.1f patches/s), save %.3f s -> %s\n", load_s, compute_s,
                n / compute_s, save_s, a.out.c_str());
  }
  if (a.json) std::cout << rec.dump() << std::endl;
  if (!a.record_path.empty()) hpcgi::record::append(a.record_path, rec);
  return 0;
}

}  // namespace radiosity::app
