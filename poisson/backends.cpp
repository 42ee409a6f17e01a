// The list of backends and the one place that maps a name to its factory.
#include "poisson/backends.hpp"

#include "common/errors.hpp"

namespace poisson {

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
  static const std::vector<BackendEntry> list = {
      {"serial", "frozen reference: plain loops, one thread", true, "", false, true},
      {"openmp", "fused kernels, OpenMP threads over rows", true, "", true, true},
      {"mpi", "row blocks across ranks (mpirun -np P), halo exchange, OpenMP inside each rank", mpi, no_mpi, true, true},
      {"cublas1", "report's cuBLAS 1: own stencil and axpby kernels, cublas dot", cuda, no_cuda, false, false},
      {"cublas2", "report's cuBLAS 2: own stencil kernel, cuBLAS dot/axpy/scal for every vector operation", cuda,
       no_cuda, false, false},
      {"cuda", "our best: fused kernels, one reduction per dot, no needless synchronisation", cuda, no_cuda, true, true},
  };
  return list;
}

namespace {
const BackendEntry& entry(const std::string& name) {
  for (const auto& b : backends())
    if (b.name == name) return b;
  throw hpcgi::UsageError("unknown backend '" + name + "' (see --help for the list)");
}
}  // namespace

std::string default_variant(const std::string& backend, const std::string& precision, const std::string& precond,
                            const std::string& method) {
  return entry(backend).onesweep && precision == "double" && precond == "none" && method == "cg" ? "onesweep"
                                                                                                 : "classic";
}

template <class T>
std::unique_ptr<Kernels<T>> make_kernels(const Config& cfg) {
  const BackendEntry* e = &entry(cfg.backend);
  if (!e->built) throw hpcgi::UsageError("backend '" + cfg.backend + "' is not available: " + e->why_not);
  if (cfg.variant != "classic" && !(cfg.variant == "onesweep" && e->onesweep))
    throw hpcgi::UsageError("backend '" + cfg.backend + "' has no variant '" + cfg.variant + "'" +
                            (e->onesweep ? " (classic or onesweep)" : " (classic only)"));
  if (cfg.precond != "none" && !(cfg.precond == "mg" && e->mg))
    throw hpcgi::UsageError("backend '" + cfg.backend + "' has no preconditioner '" + cfg.precond + "'" +
                            (e->mg ? " (none or mg)" : " (none only)"));
  if (cfg.method == "fmg" && !e->mg)
    throw hpcgi::UsageError("backend '" + cfg.backend + "' has no method 'fmg': it has no multigrid level kernels "
                            "(serial, openmp, mpi and cuda have)");
  if (cfg.method == "fmg" && (cfg.precond != "none" || cfg.variant != "classic"))
    throw hpcgi::UsageError("--method fmg is full multigrid, then V-cycles, not CG: it takes no --precond or "
                            "--variant (leave them out)");
  if (cfg.precond == "mg" && cfg.variant != "classic")
    throw hpcgi::UsageError("--precond mg runs preconditioned CG, which has no variant '" + cfg.variant +
                            "' (leave --variant out, or --variant classic)");
  if (cfg.backend == "serial") return make_serial<T>(cfg);
  if (cfg.backend == "openmp") return make_openmp<T>(cfg);
#ifdef HAVE_MPI
  if (cfg.backend == "mpi") return make_mpi<T>(cfg);
#endif
#ifdef HAVE_CUDA
  if (cfg.backend == "cublas1") return make_cublas1<T>(cfg);
  if (cfg.backend == "cublas2") return make_cublas2<T>(cfg);
  if (cfg.backend == "cuda") return make_cuda<T>(cfg);
#endif
  throw hpcgi::UsageError("backend '" + cfg.backend + "' is not available");
}
template std::unique_ptr<Kernels<float>> make_kernels(const Config&);
template std::unique_ptr<Kernels<double>> make_kernels(const Config&);

}  // namespace poisson
