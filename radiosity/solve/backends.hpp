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

}  // namespace radiosity
