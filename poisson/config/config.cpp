// The names of the choices, the table of backends and the one place a configuration is refused (config.hpp).
#include "poisson/config/config.hpp"

#include "common/errors.hpp"
#include "common/launcher.hpp"

namespace poisson {
namespace {

template <class E>
E parse(const std::string& name, const std::string& what, const std::string& known) {
  const auto& names = choice_names<E>();
  for (size_t k = 0; k < names.size(); ++k)
    if (names[k] == name) return static_cast<E>(k);
  throw hpcgi::UsageError("unknown " + what + " '" + name + "' (" + known + ")");
}

template <class E>
std::string joined() {
  std::string s;
  for (const auto& n : choice_names<E>()) s += (s.empty() ? "known: " : ", ") + n;
  return s;
}

template <class E>
const std::string& name_of(E e) {
  return choice_names<E>().at(static_cast<size_t>(e));
}

}  // namespace

template <> const std::vector<std::string>& choice_names<Backend>() {
  static const std::vector<std::string> v = {"serial", "openmp", "mpi", "cublas1", "cublas2", "cuda"};
  return v;
}
template <> const std::vector<std::string>& choice_names<Variant>() {
  static const std::vector<std::string> v = {"classic", "onesweep"};
  return v;
}
template <> const std::vector<std::string>& choice_names<Precond>() {
  static const std::vector<std::string> v = {"none", "mg"};
  return v;
}
template <> const std::vector<std::string>& choice_names<Method>() {
  static const std::vector<std::string> v = {"cg", "fmg"};
  return v;
}
template <> const std::vector<std::string>& choice_names<Halo>() {
  static const std::vector<std::string> v = {"nonblocking", "blocking"};
  return v;
}
template <> const std::vector<std::string>& choice_names<Precision>() {
  static const std::vector<std::string> v = {"float", "double"};
  return v;
}

Backend parse_backend(const std::string& n) { return parse<Backend>(n, "backend", "see --help for the list"); }
Variant parse_variant(const std::string& n) { return parse<Variant>(n, "variant", joined<Variant>()); }
Precond parse_precond(const std::string& n) { return parse<Precond>(n, "preconditioner", joined<Precond>()); }
Method parse_method(const std::string& n) { return parse<Method>(n, "method", joined<Method>()); }
Halo parse_halo(const std::string& n) { return parse<Halo>(n, "halo", joined<Halo>()); }
Precision parse_precision(const std::string& n) { return parse<Precision>(n, "precision", joined<Precision>()); }

const std::string& to_string(Backend b) { return name_of(b); }
const std::string& to_string(Variant v) { return name_of(v); }
const std::string& to_string(Precond p) { return name_of(p); }
const std::string& to_string(Method m) { return name_of(m); }
const std::string& to_string(Halo h) { return name_of(h); }
const std::string& to_string(Precision p) { return name_of(p); }

const std::vector<BackendEntry>& backends() {
#ifdef HAVE_MPI
  const bool mpi = true;
  const char* no_mpi = "";
#else
  const bool mpi = false;
  const char* no_mpi = "built without MPI (no mpicxx found at build time)";
#endif
#ifdef HAVE_CUDA
  const bool cuda = true;
  const char* no_cuda = "";
#else
  const bool cuda = false;
  const char* no_cuda = "built without CUDA (no nvcc found at build time)";
#endif
  // A row: the backend, what it runs (named flags), vectors per plain CG iteration, whether it is built.
  enum Runs : unsigned { kCpu = 0, kGpu = 1, kOneSweep = 2, kMultigrid = 4, kCublas = 8 };
  struct Build {
    bool built;
    const char* why_not;
  };
  auto row = [](Backend id, unsigned runs, int classic, int onesweep, Build b, const char* summary) {
    return BackendEntry{id, summary, (runs & kGpu) != 0, (runs & kOneSweep) != 0, (runs & kMultigrid) != 0,
                        (runs & kCublas) != 0, classic, onesweep, b.built, b.why_not};
  };
  const Build here{true, ""}, with_mpi{mpi, no_mpi}, with_cuda{cuda, no_cuda};
  static const std::vector<BackendEntry> list = {
      row(Backend::serial, kCpu | kMultigrid, kVectorsSerial, 0, here, "frozen reference: plain loops, one thread"),
      row(Backend::openmp, kCpu | kOneSweep | kMultigrid, kVectorsClassic, kVectorsOneSweep, here,
          "fused kernels, OpenMP threads over rows"),
      row(Backend::mpi, kCpu | kOneSweep | kMultigrid, kVectorsClassic, kVectorsOneSweep, with_mpi,
          "row blocks across ranks (mpirun -np P), halo exchange, OpenMP inside each rank"),
      row(Backend::cublas1, kGpu | kCublas, kVectorsCublas1, 0, with_cuda,
          "report's cuBLAS 1: own stencil and axpby kernels, cublas dot"),
      row(Backend::cublas2, kGpu | kCublas, kVectorsCublas2, 0, with_cuda,
          "report's cuBLAS 2: own stencil kernel, cuBLAS dot/axpy/scal for every vector operation"),
      row(Backend::cuda, kGpu | kOneSweep | kMultigrid, kVectorsClassic, kVectorsOneSweep, with_cuda,
          "our best: fused kernels, one reduction per dot, no needless synchronisation"),
  };
  return list;
}

const BackendEntry& backend_entry(Backend b) { return backends().at(static_cast<size_t>(b)); }

Variant default_variant(Backend b, Precision p, Precond pc, Method m) {
  return backend_entry(b).onesweep && p == Precision::double_ && pc == Precond::none && m == Method::cg
             ? Variant::onesweep
             : Variant::classic;
}

void check_config(const Config& cfg) {
  const BackendEntry& e = backend_entry(cfg.backend);
  const std::string& name = e.name();
  if (!e.built) throw hpcgi::UsageError("backend '" + name + "' is not available: " + e.why_not);
  if (cfg.variant == Variant::onesweep && !e.onesweep)
    throw hpcgi::UsageError("backend '" + name + "' has no variant 'onesweep' (classic only)");
  if (cfg.precond == Precond::mg && !e.multigrid)
    throw hpcgi::UsageError("backend '" + name + "' has no preconditioner 'mg' (none only)");
  if (cfg.method == Method::fmg && !e.multigrid)
    throw hpcgi::UsageError("backend '" + name + "' has no method 'fmg': it has no multigrid level kernels "
                            "(serial, openmp, mpi and cuda have)");
  if (cfg.method == Method::fmg && (cfg.precond != Precond::none || cfg.variant != Variant::classic))
    throw hpcgi::UsageError("--method fmg is full multigrid, then V-cycles, not CG: it takes no --precond or "
                            "--variant (leave them out)");
  if (cfg.precond == Precond::mg && cfg.variant != Variant::classic)
    throw hpcgi::UsageError("--precond mg runs preconditioned CG, which has no variant '" + to_string(cfg.variant) +
                            "' (leave --variant out, or --variant classic)");
  if (cfg.check_symmetry && cfg.precond != Precond::mg)
    throw hpcgi::UsageError("--check-symmetry checks the multigrid preconditioner: it needs --precond mg");
  if (cfg.backend != Backend::mpi && hpcgi::launched_by_mpirun_with_many_ranks())
    throw hpcgi::UsageError("backend '" + name + "' runs as one process; use --backend mpi under mpirun");
}

}  // namespace poisson
