// The backends' entry points, one file each; solve.cpp lists them in the registry.
#pragma once
#include <memory>
#include <vector>

#include "radiosity/solve/contract/kernels.hpp"
#include "radiosity/solve/config/config.hpp"
#include "radiosity/solve/core/system.hpp"

namespace radiosity {

// Kernel backends: the vectors (`vectors` slots, all zero) in cfg.layout, ready for the shared methods.
template <class T>
using KernelFactory = std::unique_ptr<Kernels<T>> (*)(const System& sys, const SolveConfig& cfg, int vectors);

template <class T>
std::unique_ptr<Kernels<T>> make_serial(const System& sys, const SolveConfig& cfg, int vectors);
template <class T>
std::unique_ptr<Kernels<T>> make_openmp(const System& sys, const SolveConfig& cfg, int vectors);

// The k-right-hand-side kernels (kernels.hpp's MultiKernels; multi_solve.hpp runs them): `vectors` slots of
// E.size() vectors each, every slot of right-hand side q starting as E[q]. serial and openmp: cpu/multi.cpp; mpi:
// mpi/multi_mpi.cpp. The GPU backends have none (multi_solve.hpp refuses them before anything is built).
template <class T>
using MultiFactory = std::unique_ptr<MultiKernels<T>> (*)(const System& sys, const std::vector<std::vector<Rgb>>& E,
                                                          const SolveConfig& cfg, int vectors);
template <class T>
std::unique_ptr<MultiKernels<T>> make_multi_serial(const System& sys, const std::vector<std::vector<Rgb>>& E,
                                                   const SolveConfig& cfg, int vectors);
template <class T>
std::unique_ptr<MultiKernels<T>> make_multi_openmp(const System& sys, const std::vector<std::vector<Rgb>>& E,
                                                   const SolveConfig& cfg, int vectors);

// RRV's own data structure and loop (original.cpp).
SolveResult run_original(const System& sys, const SolveConfig& cfg, const IterationCallback& callback);

#ifdef HAVE_MPI
// The MPI backend (mpi.cpp, compiled by the MPI wrapper): each rank's kernels over its block of rows of F, the system
// holding that block (System::rows_begin, rows_end); collective from construction on.
template <class T>
std::unique_ptr<Kernels<T>> make_mpi(const System& sys, const SolveConfig& cfg, int vectors);
// Its k-product (mpi/multi_mpi.cpp): every rank holds all of F, computes its block of rows of the k products and
// gathers the k columns (MPI_Allgatherv); collective from construction on.
template <class T>
std::unique_ptr<MultiKernels<T>> make_multi_mpi(const System& sys, const std::vector<std::vector<Rgb>>& E,
                                                const SolveConfig& cfg, int vectors);
#endif

#ifdef HAVE_CUDA
// The GPU backends (cuda_aos.cu, cublas_soa.cu, hybrid.cu). Each refuses with hpcgi::UsageError, before it
// allocates, a machine without a GPU and a system that will not fit in the GPU's free memory. solve.cpp's driver runs
// them as it runs the CPU backends (their clock reaches the record through Kernels::settled and account).
template <class T>
std::unique_ptr<Kernels<T>> make_cuda(const System& sys, const SolveConfig& cfg, int vectors);
template <class T>
std::unique_ptr<Kernels<T>> make_cublas(const System& sys, const SolveConfig& cfg, int vectors);
template <class T>
std::unique_ptr<Kernels<T>> make_hybrid(const System& sys, const SolveConfig& cfg, int vectors);
#endif

}  // namespace radiosity
