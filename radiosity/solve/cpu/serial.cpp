// Backend `serial`: the shared kernels on one thread, no OpenMP runtime involved.
#include "radiosity/solve/contract/backends.hpp"
#include "radiosity/solve/cpu/cpu_kernels.hpp"
#include "radiosity/solve/host/exec.hpp"

namespace radiosity {

template <class T>
std::unique_ptr<Kernels<T>> make_serial(const System& sys, const SolveConfig& cfg, int vectors) {
  if (grey_as_one_channel(sys, cfg)) return std::make_unique<CpuKernels<T, Grey, SerialExec>>(sys, vectors, SerialExec{});
  if (cfg.layout == Layout::soa) return std::make_unique<CpuKernels<T, Soa, SerialExec>>(sys, vectors, SerialExec{});
  return std::make_unique<CpuKernels<T, Aos, SerialExec>>(sys, vectors, SerialExec{});
}
template std::unique_ptr<Kernels<float>> make_serial(const System&, const SolveConfig&, int);
template std::unique_ptr<Kernels<double>> make_serial(const System&, const SolveConfig&, int);

}  // namespace radiosity
