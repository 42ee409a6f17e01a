#include "radiosity/app/solve_plan.hpp"

#include <cstdio>
#include <filesystem>
#include <vector>

#include "common/comm.hpp"
#include "common/errors.hpp"
#include "common/files.hpp"
#include "radiosity/solve/storage_choice.hpp"

namespace radiosity::app {
namespace {

// The files the run reads and writes, the snapshots among them.
void check_solve_files(const SolveArgs& a, SolvePlan& p) {
  std::vector<hpcgi::files::Output> outputs{{a.output_xml, "--output"}, {a.png, "--png"}};
  const long last = p.cfg.steps > 0 ? p.cfg.steps : p.cfg.max_iter;
  for (long k : a.snapshots) {
    if (k < 1 || k > last)
      throw hpcgi::UsageError("--snapshots " + std::to_string(k) + ": no such iteration (the run has at most " +
                              std::to_string(last) + ")");
    p.snapshots.emplace_back(k, snapshot_file(a.snapshot_prefix, k));
    outputs.push_back({p.snapshots.back().second, "--snapshots"});
  }
  check_files(a, outputs, {{a.ff, "--ff"}, {a.reference_ff, "--reference-ff"}});
}

// What the backend reads: its rows, its storage, its error reference.
void check_backend_reads(const SolveArgs& a, const SolvePlan& p) {
  const SolveBackend& b = *p.backend;
  if (b.distributed && !a.reference_ff.empty())
    throw hpcgi::UsageError("--reference-ff is read by one process; backend mpi takes its error reference from "
                            "--ff (solve the finer mesh with serial or openmp)");
  if (p.storage)
    require_storage(b, *p.storage, p.values);
  else if (readable_storages(b, p.values).empty())  // auto: no storage of these values at all
    require_storage(b, FFStorage::dense, p.values);
}

}  // namespace

std::string snapshot_file(const std::string& prefix, long k) {
  return (prefix.empty() ? std::string("snapshot") : prefix) + "_iter" + std::to_string(k) + ".png";
}

SolvePlan plan_solve(const SolveArgs& a) {
  SolvePlan p;
  p.cfg = a.cfg;
  p.cfg.threads = a.threads;
  // Backend mpi: every rank reads its block of rows of F and the ranks solve together; rank 0 alone prints and
  // writes (the record, the scene, the pictures). Every check before the first collective runs on every rank alike,
  // and the ranks agree on its outcome (comm::agreed), so that rank 0 alone reports a refusal.
  p.ranks = hpcgi::comm::size();
  p.rank = hpcgi::comm::rank();
  p.root = hpcgi::comm::root();
  hpcgi::comm::agreed([&] {
    std::tie(p.width, p.height) = parse_size(a.size);
    p.backend = &require_backend(p.cfg.backend);  // before anything is read for it
    p.values = parse_ff_values(a.ff_precision);
    if (a.storage != "auto") p.storage = parse_ff_storage(a.storage);
    p.limit = a.memory_limit();
    p.ff = a.ff;
    p.threshold = a.threshold;
    check_solve_files(a, p);
    check_backend_reads(a, p);
    check_config(p.cfg);  // the library's rules (solve.hpp): what the backend runs, the tolerance, omega, ...
    std::error_code ec;
    if (std::filesystem::is_regular_file(p.ff, ec)) {
      p.file = FormFactorFile::open(p.ff);
      if (p.file->sparse()) plan_sparse_file(p, p.file->info());
    }
  });
  p.dist = p.backend->distributed;
  p.min_time = a.min_time;
  p.scene = a;  // the scene's options: the SceneArgs part of the request
  p.verify = a.verify;
  p.reference_ff = a.reference_ff;
  p.reference_divide = a.reference_divide;
  p.output_xml = a.output_xml;
  p.png = a.png;
  p.view = a.view;
  p.exposure = a.exposure;
  return p;
}

void plan_sparse_file(const SolvePlan& p, const FormFactorFileInfo& info) {
  const SolveBackend& b = *p.backend;
  const std::string file = "--ff '" + p.ff + "' holds " + info.storage + " " + info.precision + " form factors";
  if (!reads_storage(b, parse_ff_storage(info.storage), parse_ff_values(info.precision)) || b.distributed)
    throw hpcgi::UsageError(file + ": backend '" + b.name + "' reads dense float32 files only (write the file with "
                            "formfactors --storage dense" +
                            (b.distributed ? "; each rank builds its rows' storage from it" : "") + ")");
  if (p.storage && *p.storage != parse_ff_storage(info.storage))
    throw hpcgi::UsageError(file + ", not " + to_string(*p.storage) + ": give --storage auto or " + info.storage);
  if (p.values != parse_ff_values(info.precision))
    throw hpcgi::UsageError(file + ": give --ff-precision " + info.precision + " (the values are read as stored)");
  if (p.threshold > 0)
    throw hpcgi::UsageError(file + ": --threshold applies when a dense file is loaded (this file's threshold is " +
                            std::to_string(info.params.threshold) + ")");
}

}  // namespace radiosity::app
