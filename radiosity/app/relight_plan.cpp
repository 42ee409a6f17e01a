// Phases 1 and 2 of `bin/radiosity relight` (relight_phases.hpp): the plan and the load.
#include <string>

#include "common/errors.hpp"
#include "common/memory.hpp"
#include "common/timer.hpp"
#include "radiosity/app/relight_phases.hpp"
#include "radiosity/formfactor/file/format.hpp"
#include "radiosity/solve/multi_solve.hpp"
#include "radiosity/solve/storage_choice.hpp"

namespace radiosity::app {

using namespace radiosity::relight;

RelightPlan plan_relight(const RelightArgs& a) {
  RelightPlan p;
  std::tie(p.width, p.height) = parse_size(a.size);
  p.values = parse_ff_values(a.ff_precision);
  // The reflectivity frames' configuration and the storage their backend reads are checked before anything is read
  // or written, by the library's rules (solve.hpp: check_config, require_storage).
  const SolveBackend& b = require_backend(a.cfg.backend);
  // The light basis runs on the backend's k-right-hand-side product (multi_solve.hpp): one without is refused here,
  // before anything is read or a device is asked for.
  if (!has_multi_rhs(b.name))
    throw hpcgi::UsageError("relight: --backend " + b.name + " has no k-right-hand-side product (the light basis " +
                            "runs on " + multi_rhs_backends() + ")");
  if (b.distributed && a.bench_rhs > 0)
    throw hpcgi::UsageError("relight --bench-rhs times one process's k-right-hand-side product; --backend " + b.name +
                            " is for the light basis (bench it with serial or openmp)");
  check_config(a.cfg);
  BasisOptions basis;  // the light basis's solve, by the same rules (its --basis-tol within double's reach)
  basis.tol = a.basis_tol;
  basis.backend = b.name;
  try {
    check_config(basis_config(basis));
  } catch (const hpcgi::UsageError& e) {
    throw hpcgi::UsageError(std::string("--basis-tol (the light basis's solve, in float64): ") + e.what());
  }
  if (a.storage != "auto") p.storage = parse_ff_storage(a.storage);
  require_storage(b, p.storage.value_or(FFStorage::dense), p.values);
  // --basis is read when it exists and written when not: either way a file, and neither --ff nor --frames.
  check_files(a, {{a.basis, "--basis"}}, {{a.ff, "--ff"}, {a.frames, "--frames"}});
  return p;
}

std::vector<Rgb> reflective_somewhere(const Mesh& m, const std::vector<NamedEntity>& named,
                                      const std::vector<Frame>& frames) {
  std::vector<Rgb> rho(m.size());
  for (size_t i = 0; i < m.size(); ++i) rho[i] = m.patches[i].reflectivity;
  for (const Frame& f : frames) {
    if (f.scene_reflectivity) continue;
    const Mesh fm = frame_mesh(m, named, f);
    for (size_t i = 0; i < m.size(); ++i)
      if (!row_needed(rho[i]) && row_needed(fm.patches[i].reflectivity)) rho[i] = fm.patches[i].reflectivity;
  }
  return rho;
}

namespace {

// F in the run's storage (--storage, or auto by the frames' values: storage_choice.hpp, as solve chooses) and
// precision, built from the file's dense values as solve builds it; the light basis's in float32.
void build_relight_matrices(const RelightArgs& a, const RelightPlan& p, RelightInputs& in) {
  hpcgi::Timer t;
  const size_t n = in.m.size();
  const float* F = in.file_matrix->dense_float32_values();
  const std::vector<Rgb> rho = reflective_somewhere(in.m, in.named, in.frames);
  if (p.storage) {
    in.storage = *p.storage;
  } else {
    const std::vector<FFStorage> readable = readable_storages(require_backend(a.cfg.backend), p.values);
    in.storage = fewest_bytes_storage(readable, p.values, count_storages(F, n, rho, 0, readable));
  }
  auto build = [&](FFValues values) {
    FFMatrixOptions opt;
    opt.storage = in.storage;
    opt.values = values;
    return std::make_unique<FormFactorMatrix>(F, n, rho, opt);
  };
  if (in.storage != FFStorage::dense || p.values != FFValues::float32) in.matrix = build(p.values);
  if (in.storage != FFStorage::dense) in.basis_matrix = p.values == FFValues::float32 ? nullptr : build(FFValues::float32);
  in.file_view = dense_float32_view(F, n);
  in.frame_view = in.matrix ? in.matrix->view() : in.file_view;
  in.frame_bytes = in.matrix ? in.matrix->bytes() : 4.0 * double(n) * double(n);
  in.basis_view = in.basis_matrix                                  ? in.basis_matrix->view()
                  : in.storage != FFStorage::dense ? in.frame_view  // float32 already
                                                   : in.file_view;
  in.ff_build_s = t.seconds();
}

}  // namespace

void load_relight(const RelightArgs& a, const RelightPlan& p, RelightInputs& in) {
  in.m = load_scene(a, &in.load_s);
  const size_t n = in.m.size();
  in.named = named_entities(in.m);
  in.lights = lights_of(in.named);
  if (a.random_frames > 0)
    in.frames = random_frames(size_t(a.random_frames), uint64_t(a.seed), in.named);
  else if (a.bench_rhs == 0)
    in.frames = read_frames(a.frames, in.m, in.named, a.load.allow_reflectivity_ge_1);
  in.cam = parse_view(a.view, in.m);
  // Backend mpi solves the light basis on the ranks; a frame that changes a reflectivity would be a solve of rank 0
  // alone, which that backend does not run.
  if (require_backend(a.cfg.backend).distributed)
    for (size_t k = 0; k < in.frames.size(); ++k)
      if (!in.frames[k].scene_reflectivity)
        throw hpcgi::UsageError("relight --backend " + a.cfg.backend + ": frame " + std::to_string(k) +
                                " changes a reflectivity; on MPI ranks relight serves frames of lights only (run "
                                "reflectivity frames with --backend openmp)");
  // Every frame's picture passes the output check with the run's other outputs, before anything is computed: no
  // input (the form factors, the scene, its meshes, the basis) and no device or FIFO named PREFIX_0000.png is replaced.
  if (!a.png_frames.empty()) {
    std::vector<hpcgi::files::Output> outputs{{a.basis, "--basis"}};
    for (size_t k = 0; k < in.frames.size(); ++k) outputs.push_back({png_frame_file(a.png_frames, k), "--png-frames"});
    check_files(a, outputs, {{a.ff, "--ff"}, {a.frames, "--frames"}});
  }
  const double n2 = double(n) * double(n);
  // At most: the dense values, a 16-bit dense copy for the frames (a sparse copy holds fewer values) and a float32
  // sparse one for the light basis (fewer than the dense values, and then no dense copy); with two or more lights
  // (or right-hand sides), F's row blocks while the basis is solved (row_blocks.hpp: at most the dense values).
  const bool blocks = in.lights.size() > 1 || a.bench_rhs > 1;
  hpcgi::require_host_memory("relighting " + std::to_string(n) + " patches (dense float32 form factors, a copy in "
                             "--storage" + std::string(blocks ? " and their row blocks for the light basis)" : ")"),
                             4 * n2 + (p.values != FFValues::float32 || p.storage != FFStorage::dense ? 4 * n2 : 0) +
                                 (blocks ? 4 * n2 : 0));
  hpcgi::Timer t;
  in.ff_file = FormFactorFile::open(a.ff).checked(in.m).require_dense();
  in.file_matrix = std::make_unique<FormFactorMatrix>(read_form_factors(in.ff_file, in.m));
  in.ff_load_s = t.seconds();
  build_relight_matrices(a, p, in);
}

}  // namespace radiosity::app
