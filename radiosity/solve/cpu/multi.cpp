// The serial and openmp backends' k-right-hand-side kernels (cpu/multi_kernels.hpp) with their executors.
#include "radiosity/solve/contract/backends.hpp"
#include "radiosity/solve/cpu/multi_kernels.hpp"
#include "radiosity/solve/host/exec.hpp"

namespace radiosity {

template <class T>
std::unique_ptr<MultiKernels<T>> make_multi_serial(const System& sys, const std::vector<std::vector<Rgb>>& E,
                                                   const SolveConfig&, int vectors) {
  return std::make_unique<CpuMultiKernels<T, SerialExec>>(sys, E, vectors, SerialExec{});
}

template <class T>
std::unique_ptr<MultiKernels<T>> make_multi_openmp(const System& sys, const std::vector<std::vector<Rgb>>& E,
                                                   const SolveConfig& cfg, int vectors) {
  return std::make_unique<CpuMultiKernels<T, OpenMPExec>>(sys, E, vectors, OpenMPExec(cfg.threads));
}

#define HPCGI_MULTI(T)                                                                                           \
  template std::unique_ptr<MultiKernels<T>> make_multi_serial(const System&, const std::vector<std::vector<Rgb>>&, \
                                                              const SolveConfig&, int);                         \
  template std::unique_ptr<MultiKernels<T>> make_multi_openmp(const System&, const std::vector<std::vector<Rgb>>&, \
                                                              const SolveConfig&, int);
HPCGI_MULTI(float)
HPCGI_MULTI(double)
#undef HPCGI_MULTI

}  // namespace radiosity
