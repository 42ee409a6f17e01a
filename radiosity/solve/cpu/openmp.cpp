// Backend `openmp`: the shared kernels with OpenMP threads over rows, static blocks aligned to cache lines
// (report §3.8.2: only the linear algebra is threaded; F is shared, never copied).
#include "radiosity/solve/contract/backends.hpp"
#include "radiosity/solve/cpu/cpu_kernels.hpp"
#include "radiosity/solve/host/exec.hpp"

namespace radiosity {

template <class T>
std::unique_ptr<Kernels<T>> make_openmp(const System& sys, const SolveConfig& cfg, int vectors) {
  const OpenMPExec ex(cfg.threads);
  if (grey_as_one_channel(sys, cfg)) return std::make_unique<CpuKernels<T, Grey, OpenMPExec>>(sys, vectors, ex);
  if (cfg.layout == Layout::soa) return std::make_unique<CpuKernels<T, Soa, OpenMPExec>>(sys, vectors, ex);
  return std::make_unique<CpuKernels<T, Aos, OpenMPExec>>(sys, vectors, ex);
}
template std::unique_ptr<Kernels<float>> make_openmp(const System&, const SolveConfig&, int);
template std::unique_ptr<Kernels<double>> make_openmp(const System&, const SolveConfig&, int);

}  // namespace radiosity
