// `bin/radiosity formfactors`: the hemicube once, into a form-factor file named for the mesh (report §3.6). Under
// mpirun (MPI_Init by main) every rank computes its block of rows, balanced by an estimate of each row's hemicube
// work, and the ranks write the one file together with MPI-IO (radiosity/dist/).
#include <filesystem>

#include "common/comm.hpp"
#include "common/cli.hpp"
#include "common/record.hpp"
#include "common/timer.hpp"
#include "radiosity/app/commands.hpp"
#include "radiosity/app/formfactors_phases.hpp"

namespace radiosity::app {

void add_formfactors(CLI::App& app, FormFactorArgs& a) {
  CLI::App* cmd = app.add_subcommand(
      "formfactors",
      "compute the form factors of a scene by the hemicube into a file; under mpirun -np P every rank computes a "
      "block of rows (balanced by estimated work) and the ranks write the one file together (MPI-IO): the same bytes "
      "as one process writes, so any number of ranks, or the serial program, reads it");
  add_scene_options(cmd, a);
  add_memory_option(cmd, a);
  cmd->add_option("-o,--out", a.out, "form-factor file to write")->required();
  cmd->add_option("--hemicube", a.hemicube.resolution, "hemicube resolution R (top face R x R)")
      ->capture_default_str();
  cmd->add_option("--weights", a.weights, "exact (Cohen-Greenberg delta form factors) or rrv2007 (RRV's cos*cos)")
      ->check(CLI::IsMember({"exact", "rrv2007"}))->capture_default_str();
  cmd->add_option("--threshold", a.hemicube.threshold, "store form factors <= T as 0 (RRV's threshold)")
      ->check(hpcgi::fraction_below_one())->capture_default_str();
  cmd->add_option("--split", a.split,
                  "under mpirun: rows in blocks of equal estimated hemicube work (work) or of equal count (rows, to "
                  "compare)")
      ->check(CLI::IsMember({"work", "rows"}))->capture_default_str();
  cmd->add_option("--storage", a.storage,
                  "the file's storage: dense (version 1, what every reader takes) | csr | compressed | runs (version 2: "
                  "only the non-zero F_ij, read by solve on serial and openmp; one process)")
      ->check(CLI::IsMember({"dense", "csr", "compressed", "runs"}))->capture_default_str();
  cmd->add_option("--ff-precision", a.ff_precision,
                  "the values of a csr, compressed or runs file: float32 | float16 (scaled by a power of two) | bfloat16")
      ->check(CLI::IsMember({"float32", "float16", "bfloat16"}))->capture_default_str();
}

int run_formfactors(const FormFactorArgs& a) {
  hpcgi::Timer total;
  const FormFactorPlan plan = plan_formfactors(a);
  double load_s = 0;
  const Mesh m = hpcgi::comm::agreed([&] {
    Mesh mesh = load_scene(a, &load_s);
    require_rows_for_ranks(mesh.size(), hpcgi::comm::size());
    return mesh;
  });
  const FormFactorSplit split = split_formfactors(a, m, plan);
  ComputedRows c = compute_formfactors(a, m, plan, split);
  const WriteStats w = write_formfactors(a, m, c.rows);
  nlohmann::json rec = formfactors_record(a, m, plan, split, c, w, {load_s, total.seconds()});  // collective
  if (!hpcgi::comm::root()) return 0;
  rec["result"]["file_bytes"] = std::filesystem::file_size(a.out);
  if (!a.quiet) print_formfactors_summary(a, m, plan, split, c, w, load_s);
  hpcgi::record::emit(rec, a);
  return 0;
}

}  // namespace radiosity::app
