// Phases 1 and 2 of `bin/radiosity relight` (relight_phases.hpp): the plan and the load.
#include <string>

#include "common/errors.hpp"
#include "common/memory.hpp"
#include "common/timer.hpp"
#include "radiosity/app/relight_phases.hpp"
#include "radiosity/formfactor/ff_file.hpp"

namespace radiosity::app {

using namespace radiosity::relight;

RelightPlan plan_relight(const RelightArgs& a) {
  RelightPlan p;
  std::tie(p.width, p.height) = parse_size(a.size);
  p.values = parse_ff_values(a.ff_precision);
  // The reflectivity frames' configuration and the storage their backend reads are checked before anything is read
  // or written, by the library's rules (solve.hpp: check_config, require_storage).
  check_config(a.cfg);
  require_storage(require_backend(a.cfg.backend), FFStorage::dense, p.values);
  // --basis is read when it exists and written when not: either way a file, and neither --ff nor --frames.
  check_files(a, {{a.basis, "--basis"}}, {{a.ff, "--ff"}, {a.frames, "--frames"}});
  return p;
}

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
  const double n2 = double(n) * double(n);
  hpcgi::require_host_memory("relighting " + std::to_string(n) + " patches (dense float32 form factors and a 16-bit "
                             "copy)", 4 * n2 + (p.values != FFValues::float32 ? 2 * n2 : 0));
  hpcgi::Timer t;
  in.ff = load_form_factors(a.ff, in.m);
  in.ff_load_s = t.seconds();
  if (p.values != FFValues::float32) {
    std::vector<Rgb> rho(n);
    for (size_t i = 0; i < n; ++i) rho[i] = in.m.patches[i].reflectivity;
    FFMatrixOptions opt;
    opt.values = p.values;
    in.matrix = std::make_unique<FormFactorMatrix>(in.ff.values.data(), n, rho, opt);
  }
  in.file_view = dense_float32_view(in.ff.values.data(), n);
  in.frame_view = in.matrix ? in.matrix->view() : in.file_view;
}

}  // namespace radiosity::app
