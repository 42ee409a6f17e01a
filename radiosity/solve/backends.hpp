// The backends' entry points, one file each; solve.cpp lists them in the registry.
#pragma once
#include <memory>

#include "radiosity/solve/kernels.hpp"
#include "radiosity/solve/solve.hpp"

namespace radiosity {

// Kernel backends: the vectors (`vectors` slots, all zero) in cfg.layout, ready for the shared methods.
template <class T>
using KernelFactory = std::unique_ptr<Kernels<T>> (*)(const System& sys, const SolveConfig& cfg, int vectors);

template <class T>
std::unique_ptr<Kernels<T>> make_serial(const System& sys, const SolveConfig& cfg, int vectors);
template <class T>
std::unique_ptr<Kernels<T>> make_openmp(const System& sys, const SolveConfig& cfg, int vectors);

// RRV's own data structure and loop (original.cpp).
SolveResult run_original(const System& sys, const SolveConfig& cfg, const IterationCallback& callback);

#ifdef HAVE_MPI
// The MPI backend (mpi.cpp, compiled by the MPI wrapper): each rank's kernels over its block of rows of F, the system
// holding that block (System::rows_begin, rows_end); collective from construction on.
template <class T>
std::unique_ptr<Kernels<T>> make_mpi(const System& sys, const SolveConfig& cfg, int vectors);
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
