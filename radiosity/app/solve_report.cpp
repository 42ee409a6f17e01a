#include "radiosity/app/solve_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "common/comm.hpp"
#include "common/record.hpp"
#include "radiosity/render/png_writer.hpp"
#include "radiosity/scene/rrv_writer.hpp"

namespace radiosity::app {
namespace {

using nlohmann::json;

json or_null(bool given, const json& v) { return given ? v : json(); }

json params_json(const SolveReport& r) {
  const SolvePlan& p = r.p;
  const SolveConfig& cfg = p.cfg;
  const HemicubeParams& hemicube = r.L.params;
  const bool split = r.p.backend->splits_rows, fixed = cfg.steps > 0;
  return {{"command", "solve"},
          {"scene", p.scene.scene},
          {"patches", r.L.m.size()},
          {"divide", p.scene.load.divide},
          {"method", to_string(cfg.method)},
          {"layout", to_string(cfg.layout)},
          {"backend", cfg.backend},
          {"precision", to_string(cfg.precision)},
          {"steps", cfg.steps},
          {"tol", or_null(!fixed, cfg.tol)},
          {"stop", or_null(!fixed, to_string(cfg.stop))},
          {"start", to_string(cfg.start)},
          {"omega", or_null(cfg.method == Method::sor, cfg.omega)},
          {"history", cfg.history},
          {"max_iter", cfg.max_iter},
          {"threads", r.run.res.threads},
          {"hemicube", hemicube.resolution},
          {"weights", to_string(hemicube.weights)},
          {"ff_threshold", hemicube.threshold},
          {"ff_file", p.ff},
          {"storage", to_string(r.L.storage)},
          {"storage_requested", p.storage ? to_string(*p.storage) : "auto"},
          {"ff_precision", to_string(r.p.values)},
          {"threshold", p.threshold},
          {"channels", to_string(cfg.channels)},
          {"reference_ff", or_null(!p.reference_ff.empty(), p.reference_ff)},
          {"reference_divide", or_null(p.reference_divide > 0, p.reference_divide)},
          {"fused", or_null(r.p.backend->fuses, cfg.fused)},
          {"distribution", or_null(split, cfg.distribution)},
          {"overlap", or_null(split, cfg.overlap)}};
}

json result_json(const SolveReport& r) {
  const SolveResult& res = r.run.res;
  const Loaded& L = r.L;
  json j = {{"status", to_string(res.status)},
            {"converged", res.status == SolveStatus::converged},
            {"iterations", res.iterations},
            {"rel_residual", res.rel_residual},
            {"max_rel_residual", *std::max_element(res.rel_residual.begin(), res.rel_residual.end())},
            {"mesh_hash", mesh_hash(L.m)},
            {"channels", res.channels},
            {"kept", L.kept},
            {"density", double(L.kept) / L.n2},
            {"skipped_rows", L.skipped_rows},
            {"matrix_storage_bytes", L.matrix_storage_bytes}};
  if (!res.detail.empty()) j["detail"] = res.detail;
  return j;
}

// The range of B, for scenes whose answer is known in closed form (a closed box: E / (1 - ρ)).
void add_radiosity_range(json& result, const std::vector<Rgb>& B) {
  Rgb lo{HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi{-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  for (const Rgb& b : B)
    for (int c = 0; c < 3; ++c) {
      lo[c] = std::min(lo[c], b[c]);
      hi[c] = std::max(hi[c], b[c]);
    }
  result["radiosity_min"] = lo;
  result["radiosity_max"] = hi;
}

// result.error_vs_reference, result.reference and the verify section.
void add_verification(json& rec, const SolveReport& r) {
  const ErrorReference& ref = r.c.ref;
  if (!r.c.made) {
    rec["result"]["error_vs_reference"] = nullptr;
    rec["verify"] = {{"agreed", nullptr}};
    return;
  }
  rec["result"]["error_vs_reference"] = r.c.error;
  rec["result"]["reference"] = {{"of", ref.of},
                                {"precision", "double"},
                                {"tol", kReferenceTol},
                                {"method", ref.method},
                                {"iterations", ref.iterations},
                                {"max_rel_residual", ref.max_rel_residual},
                                {"converged", ref.converged},
                                {"patches", ref.patches},
                                {"seconds", ref.seconds}};
  rec["verify"] = {{"reference", holds_all_rows(r.L.sys) ? "float64, openmp backend (bit-identical to serial), aos"
                                                         : "float64, mpi backend on the same ranks, aos"},
                   {"reference_iterations", r.c.v.reference_iterations},
                   {"max_rel_diff", r.c.v.max_rel_diff},
                   {"bound", r.c.v.bound},
                   {"agreed", r.c.v.agreed}};
}

double per_iteration_s(const SolveResult& res) {
  return res.iterations > 0 ? res.solve_s / static_cast<double>(res.iterations) : 0.0;
}
double bandwidth_GBps(const SolveResult& res) {
  return res.solve_s > 0 ? res.matrix_bytes * static_cast<double>(res.matrix_passes) / res.solve_s / 1e9 : 0.0;
}
bool on_gpu(const SolveResult& res) { return res.backend_info.count("gpu") > 0; }  // the GPU backends describe it

void add_times_and_perf(json& rec, const SolveReport& r) {
  const SolveResult& res = r.run.res;
  const bool gpu = on_gpu(res);
  rec["times_s"] = {{"load", r.L.load_s},     {"ff_load", r.L.ff_load_s},     {"ff_build", r.L.ff_build_s},
                    {"setup", res.setup_s},   {"solve", res.solve_s},         {"per_iteration", per_iteration_s(res)},
                    {"check", res.check_s},   {"verify", r.c.v.seconds},      {"reference", r.c.ref.seconds},
                    {"total", r.total_s}};
  if (gpu) {
    rec["times_s"]["upload"] = res.upload_s;
    rec["times_s"]["transfer"] = res.transfer_s;
    rec["times_s"]["device_compute"] = res.device_compute_s;
    rec["times_s"]["host_compute"] = res.host_compute_s;
  }
  if (r.p.min_time > 0) rec["repetitions"] = hpcgi::to_json(r.run.reps);
  rec["perf"] = {{"matrix_bytes", res.matrix_bytes},
                 {"matrix_passes", res.matrix_passes},
                 {"bandwidth_GBps", bandwidth_GBps(res)},
                 {"peak_rss_bytes", peak_rss_bytes()},
                 {"timer", gpu ? "host wall clock, device synchronised; upload, transfer and device_compute by CUDA "
                                 "events, host_compute by the host's clock"
                               : "host wall clock"}};
  if (gpu) rec["perf"]["transfer_bytes"] = res.transfer_bytes;
  if (!res.read_sweep_s.empty()) {
    std::vector<double> t = res.read_sweep_s;
    std::sort(t.begin(), t.end());
    const double median = t.size() % 2 ? t[t.size() / 2] : 0.5 * (t[t.size() / 2 - 1] + t[t.size() / 2]);
    rec["times_s"]["read_sweep_best"] = t.front();
    rec["times_s"]["read_sweep_median"] = median;
    rec["perf"]["read_sweep_bytes"] = res.read_sweep_bytes;
    rec["perf"]["read_sweeps"] = t.size();
    rec["perf"]["read_sweep_GBps"] = res.read_sweep_bytes / t.front() / 1e9;
    rec["perf"]["read_sweep_median_GBps"] = res.read_sweep_bytes / median / 1e9;
  }
}

// Backend mpi: params.ranks and the mpi section (collective).
void add_mpi(json& rec, const SolveReport& r) {
  const SolveResult& res = r.run.res;
  rec["params"]["ranks"] = r.p.ranks;
  json mpi = mpi_section(r.L.rank_needs, r.p.limit);  // collective
  mpi["split"] = "rows in blocks of equal count (the memory of F per rank)";
  mpi["file"] = "each rank reads its rows of the one form-factor file (MPI-IO), the checksum chained over the ranks";
  mpi["rank_read_s"] = hpcgi::comm::gather(r.L.rank_read_s);
  mpi["rank_checksum_s"] = hpcgi::comm::gather(r.L.rank_checksum_s);
  mpi["rank_chain_wait_s"] = hpcgi::comm::gather(r.L.rank_chain_s);
  for (const auto& [key, v] : res.per_rank) mpi["rank_" + key] = v;
  for (const auto& [key, v] : res.comm) mpi[key] = v;
  rec["mpi"].update(mpi);  // beside the hosts record::make put there
}

void print_per_rank(const SolveResult& res, int ranks) {
  std::printf("  ranks: %d; rows", ranks);
  for (double x : res.per_rank.at("rows")) std::printf(" %.0f", x);
  std::printf("; F held MiB");
  for (double b : res.per_rank.at("ff_bytes")) std::printf(" %.1f", b / (1 << 20));
  std::printf("; received per iteration KiB");
  for (double b : res.per_rank.at("received_bytes_per_iteration")) std::printf(" %.1f", b / 1024);
  std::printf("; in MPI s");
  for (double x : res.per_rank.at("comm_s")) std::printf(" %.4f", x);
  std::printf("\n");
}

}  // namespace

json solve_record(const SolveReport& r) {
  const SolveResult& res = r.run.res;
  json rec = hpcgi::record::make("radiosity");
  rec["params"] = params_json(r);
  rec["result"] = result_json(r);
  hpcgi::record::set_outcome(rec, r.c.outcome);
  if (r.p.cfg.history) rec["result"]["history"] = history_json(res, r.p.cfg);
  if (!failed(res.status)) add_radiosity_range(rec["result"], res.B);
  add_verification(rec, r);
  add_times_and_perf(rec, r);
  if (r.p.dist) add_mpi(rec, r);
  json info = {{"threads", std::to_string(res.threads)}};
  for (const auto& [key, value] : res.backend_info) info[key] = value;
  rec["backend_info"] = info;
  return rec;
}

json history_json(const SolveResult& res, const SolveConfig& cfg) {
  json h = {{"rule", to_string(cfg.stop)}, {"e2", res.e2}, {"r0_2", res.r0_2}};
  const StopRule& rule = cfg.stop;
  const StopRule measures[] = {parse_stop_rule("residual-e"), parse_stop_rule("residual-e+stacked"),
                               parse_stop_rule("step-2"), parse_stop_rule("step-2+stacked"),
                               parse_stop_rule("step-inf"), parse_stop_rule("step-inf+stacked")};
  const char* names[] = {"rel_residual_e", "rel_residual_e_stacked", "rel_step_2", "rel_step_2_stacked",
                         "rel_step_inf", "rel_step_inf_stacked"};
  for (const char* key : {"iteration", "res2", "step2", "step_inf", "b2", "b_inf", "rule_value", names[0], names[1],
                          names[2], names[3], names[4], names[5]})
    h[key] = json::array();
  for (const IterateNorms& k : res.history) {
    h["iteration"].push_back(k.iteration);
    h["res2"].push_back(k.res2);
    h["step2"].push_back(k.step2);
    h["step_inf"].push_back(k.step_inf);
    h["b2"].push_back(k.b2);
    h["b_inf"].push_back(k.b_inf);
    h["rule_value"].push_back(rule.value(k, res.e2, res.r0_2));
    for (int m = 0; m < 6; ++m) {
      const Rgb v = measures[m].values(k, res.e2, res.r0_2);
      if (m % 2)
        h[names[m]].push_back(v[0]);
      else
        h[names[m]].push_back(v);
    }
  }
  return h;
}

void print_summary(const SolveReport& r) {
  const SolveConfig& cfg = r.p.cfg;
  const Loaded& L = r.L;
  const SolveResult& res = r.run.res;
  std::printf("solve: %s, %zu patches, %s %s %s %s, %d threads, %d channel%s\n", r.p.scene.scene.c_str(), L.m.size(),
              to_string(cfg.method).c_str(), to_string(cfg.layout).c_str(), cfg.backend.c_str(),
              to_string(cfg.precision).c_str(), res.threads,
              res.channels, res.channels == 1 ? " (grey scene)" : "s");
  std::printf("  form factors: %s%s %s, threshold %g: %zu of %.0f kept (%.2f%%), %.1f MB; %zu rows skipped (reflectivity 0)\n",
              to_string(L.storage), !r.p.storage ? " (auto: the fewest bytes per step, sparse below half of dense's)" : "",
              to_string(r.p.values), r.p.threshold, L.kept, L.n2, 100.0 * double(L.kept) / L.n2,
              L.matrix_storage_bytes / 1e6, L.skipped_rows);
  const bool sor = cfg.method == Method::sor;
  if (cfg.stop != StopRule{} || cfg.start != Start::rrv || sor)
    std::printf("  stopping rule %s, start %s%s\n", cfg.steps > 0 ? "(fixed steps)" : to_string(cfg.stop).c_str(),
                to_string(cfg.start).c_str(), sor ? (", omega " + std::to_string(cfg.omega)).c_str() : "");
  std::printf("  status %s after %ld iterations: relative residual r %.3e g %.3e b %.3e\n", to_string(res.status),
              res.iterations, res.rel_residual[0], res.rel_residual[1], res.rel_residual[2]);
  if (!res.detail.empty()) std::printf("  %s\n", res.detail.c_str());
  if (r.c.made) {
    std::printf("  float64 reference: max relative difference %.3e (bound %.1e): %s\n", r.c.v.max_rel_diff,
                r.c.v.bound, r.c.v.agreed ? "agreed" : "DISAGREED");
    std::printf("  error against the float64 solution to %.0e of %s: %.3e%s\n", kReferenceTol, r.c.ref.of.c_str(),
                r.c.error, r.c.ref.converged ? "" : " (that solution did not converge: no error bound)");
  }
  std::printf("  time: load %.3f s, form factors %.3f s, setup %.4f s, solve %.4f s (%.4g ms/iteration, %.2f GB/s)\n",
              L.load_s, L.ff_load_s, res.setup_s, res.solve_s, per_iteration_s(res) * 1e3, bandwidth_GBps(res));
  if (!hpcgi::describe(r.run.reps).empty()) std::printf("  timed: %s\n", hpcgi::describe(r.run.reps).c_str());
  if (!res.read_sweep_s.empty()) {
    const double best = *std::min_element(res.read_sweep_s.begin(), res.read_sweep_s.end());
    std::printf("  read sweeps of F's arrays: %.1f MB in %.4g ms at best of %zu (%.2f GB/s); a step took %.2fx that\n",
                res.read_sweep_bytes / 1e6, best * 1e3, res.read_sweep_s.size(), res.read_sweep_bytes / best / 1e9,
                per_iteration_s(res) / best);
  }
  if (r.p.dist) print_per_rank(res, r.p.ranks);
  if (on_gpu(res))
    std::printf("  device: %s; upload of F %.4f s; during the solve: transfers %.4f s (%.3g MB), device compute "
                "%.4f s, host compute %.4f s\n",
                res.backend_info.at("gpu").c_str(), res.upload_s, res.transfer_s, res.transfer_bytes / 1e6,
                res.device_compute_s, res.host_compute_s);
}

void finish_solve(const SolveReport& r, const nlohmann::json& rec) {
  if (!r.p.root) {  // rank 0 reports; the others end with the same status
    hpcgi::finish(r.c.outcome, true);
    return;
  }
  if (!r.p.scene.quiet) print_summary(r);
  // A run that is no answer (failed, stopped at --max-iter, disagreed with its check) is no scene and no picture:
  // only its record is written.
  const bool answer = r.c.outcome.status == hpcgi::kExitOk;
  const SolveRun& run = r.run;
  if (answer && !r.p.output_xml.empty()) write_rrv_xml(r.p.output_xml, r.L.m, run.res.B);
  if (answer && !r.p.png.empty())
    write_png(r.p.png, render(r.L.m, run.res.B, run.cam, r.p.width, r.p.height, run.ropt));
  if (!r.p.scene.quiet)
    for (const auto& f : run.snapshot_files) std::printf("  snapshot %s\n", f.c_str());
  hpcgi::record::emit(rec, r.p.scene);
  hpcgi::finish(r.c.outcome, r.p.dist);
}

}  // namespace radiosity::app
