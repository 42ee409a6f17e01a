// The one place that maps a backend to its factory (the table of backends and the checks: config.cpp).
#include "poisson/contract/backends.hpp"

#include "common/errors.hpp"

namespace poisson {

template <class T>
std::unique_ptr<Kernels<T>> make_kernels(const Config& cfg) {
  check_config(cfg);  // refuses what this binary or this backend cannot run
  switch (cfg.backend) {
    case Backend::serial: return make_serial<T>(cfg);
    case Backend::openmp: return make_openmp<T>(cfg);
#ifdef HAVE_MPI
    case Backend::mpi: return make_mpi<T>(cfg);
#endif
#ifdef HAVE_CUDA
    case Backend::cublas1: return make_cublas1<T>(cfg);
    case Backend::cublas2: return make_cublas2<T>(cfg);
    case Backend::cuda: return make_cuda<T>(cfg);
#endif
    default: break;
  }
  throw hpcgi::UsageError("backend '" + to_string(cfg.backend) + "' is not available");
}
template std::unique_ptr<Kernels<float>> make_kernels(const Config&);
template std::unique_ptr<Kernels<double>> make_kernels(const Config&);

}  // namespace poisson
