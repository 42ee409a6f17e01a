// The subcommands of bin/radiosity: their options (CLI11) and what they run. One file per subcommand.
#pragma once
#include <CLI/CLI.hpp>

#include <string>
#include <utility>
#include <vector>

#include "common/files.hpp"
#include "common/record.hpp"

#include "radiosity/formfactor/file/file.hpp"
#include "radiosity/formfactor/form_factors.hpp"
#include "radiosity/scene/rrv_reader.hpp"
#include "radiosity/solve/solve.hpp"

namespace radiosity::app {

// What every subcommand that reads a scene shares.
struct SceneArgs : hpcgi::record::Options {  // --record, --json, --quiet
  std::string scene;
  LoadOptions load;
  int threads = 0;
  std::string max_memory_per_rank;  // formfactors, solve: what one process (MPI rank) may hold, e.g. 64M
  double memory_limit() const;      // its bytes, 0 when not given
};
void add_scene_options(CLI::App* cmd, SceneArgs& a);
// --max-memory-per-rank, for the subcommands that hold form factors.
void add_memory_option(CLI::App* cmd, SceneArgs& a);
// Loads and subdivides the scene (sets the thread count first); prints nothing.
Mesh load_scene(const SceneArgs& a, double* seconds);
// The form factors of a form-factor file for mesh m, as `how` asks (radiosity/formfactor/file/file.hpp: every row,
// or an MPI rank's block; a sparse file as stored), the file checked against m first (its header is not read
// again): the one call of the application into the file's reader (solve's load and error reference, relight, web).
FormFactorMatrix read_form_factors(const FormFactorFile& file, const Mesh& m, const FormFactorRead& how = {});
// An MPI run gives each rank a block of rows: more ranks than patches are refused (every rank alike, one line).
void require_rows_for_ranks(size_t patches, int ranks);
// Before anything is computed: the scene and `inputs` are files, `outputs` and --record can be written without
// harm (common/files.hpp: no device, FIFO or folder replaced, no input overwritten, no output twice).
void check_files(const SceneArgs& a, std::vector<hpcgi::files::Output> outputs,
                 const std::vector<hpcgi::files::Output>& inputs);

// An option whose value is one of a SolveConfig choice's names (radiosity/solve/config/choices.hpp; `only` those of them
// where given): CLI11 checks the name, its callback parses it into `value`, once; --help shows the default's name.
template <class E>
CLI::Option* add_choice(CLI::App* cmd, const std::string& flag, E& value, E (*parse)(const std::string&),
                        const std::string& help, const std::vector<E>& only = {}) {
  std::vector<std::string> names;
  for (E e : only) names.push_back(to_string(e));
  if (only.empty()) names = choice_names<E>();
  return cmd->add_option_function<std::string>(flag, [&value, parse](const std::string& s) { value = parse(s); }, help)
      ->check(CLI::IsMember(names))
      ->default_str(to_string(value));
}

// --list-backends [--json]: the registry of solve backends as text or one JSON object (list_backends.cpp).
std::string describe_backends(bool json);

// --size WIDTHxHEIGHT of a picture, 1..16384 pixels each; hpcgi::UsageError otherwise.
std::pair<int, int> parse_size(const std::string& s);

struct InfoArgs : SceneArgs {};
void add_info(CLI::App& app, InfoArgs& a);
int run_info(const InfoArgs& a);

struct FormFactorArgs : SceneArgs {
  std::string out;
  HemicubeParams hemicube;
  std::string weights = "exact";
  std::string split = "work";  // under MPI: rows in blocks of equal estimated work, or of equal count ("rows")
  std::string storage = "dense", ff_precision = "float32";  // the file's: dense (version 1) or sparse (version 2)
};
void add_formfactors(CLI::App& app, FormFactorArgs& a);
int run_formfactors(const FormFactorArgs& a);

struct SolveArgs : SceneArgs {
  std::string ff;
  SolveConfig cfg;
  std::string storage = "auto";         // auto (storage_choice.hpp) | dense | csr | compressed | runs
  std::string ff_precision = "float32";  // float32 | float16 | bfloat16: how F is stored
  double threshold = 0;                  // drop |F_ij| <= threshold at load
  std::string reference_ff;              // the error reference's form factors (default: --ff)
  double reference_divide = 0;           // > 0: the error reference's mesh (a finer --divide of the scene)
  std::string output_xml, png, view = "auto", size = "800x600";
  double exposure = 1;
  std::vector<long> snapshots;
  std::string snapshot_prefix;
  bool verify = true;
  double min_time = 0;  // --min-time: a short solve repeated, its median repetition kept (common/repetitions.hpp)
};
void add_solve(CLI::App& app, SolveArgs& a);
int run_solve(const SolveArgs& a);

// relight (relight_cmd.cpp): frames of new lights and reflectivities over fixed form factors (issue 20).
struct RelightArgs : SceneArgs {
  std::string ff, frames, basis;
  long random_frames = 0;
  long seed = 1;
  double basis_tol = 1e-7;
  SolveConfig cfg;                       // the reflectivity frames' solves (cfg.tol: --tol); cfg.backend: the
                                         //   light basis's too (a backend with a k-right-hand-side product)
  std::string ff_precision = "float32";  // how the reflectivity frames' F is stored
  std::string storage = "auto";          // F's storage (basis, frames, bench): auto | dense | csr | compressed | runs
  double frame_budget_ms = 0;
  long check_every = 0;
  long record_patches = 0;
  std::string png_frames, view = "auto", size = "400x300";
  double exposure = 1;
  long bench_rhs = 0, passes = 10;
};
void add_relight(CLI::App& app, RelightArgs& a);
int run_relight(const RelightArgs& a);

// web (web_cmd.cpp): one self-contained HTML page that relights the scene from its light basis with WebGL.
struct WebArgs : SceneArgs {
  std::string ff, basis, out, view = "inside";
  double basis_tol = 1e-7;
  double exposure = 1;
};
void add_web(CLI::App& app, WebArgs& a);
int run_web(const WebArgs& a);

}  // namespace radiosity::app
