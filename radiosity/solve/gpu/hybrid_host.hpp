// The CPU's share of backend hybrid (report §3.8.3): rows [first, n) of every operation, computed by the openmp
// backend's own code (linalg.hpp over OpenMP threads) on vectors of all n patches as {r, g, b} records. With
// first = 0 it computes bit for bit what backend openmp computes: the same row blocks for the threads, the same
// function for a row.
//
// Defined in hybrid_host.cpp, not in hybrid.cu: nvcc hands host code to the host compiler without the CPU
// backends' flags (-march=native), and linalg.hpp's functions instantiated there would be other machine code under
// the same names, of which the linker keeps one for every backend. Hence also the pointer to the implementation:
// this header shows hybrid.cu no template of linalg.hpp.
#pragma once
#include <cstddef>
#include <memory>
#include <vector>

#include "radiosity/mesh.hpp"
#include "radiosity/solve/core/system.hpp"

namespace radiosity {

// The rows of n on the GPU at distribution d in [0, 1]: ⌈d n⌉, so any d > 0 puts at least one row there. d comes
// in decimal (0.1, 0.7, ...), and its binary value may put d·n a hair (1e-9) above an integer that the decimal hits
// exactly; the ceiling does not turn that into one row more. Here, not in hybrid.cu, so it is tested without a GPU.
size_t gpu_rows(size_t n, double d);

template <class T>
class HostRows {
 public:
  // threads = 0: the OpenMP default. F, ρ and E are read from sys, which must outlive this object.
  HostRows(const System& sys, size_t first, int vectors, int threads);
  ~HostRows();
  HostRows(const HostRows&) = delete;
  HostRows& operator=(const HostRows&) = delete;

  int threads() const;
  T* data(int v);                                // slot v: patch i's channel c at [3 i + c], all n patches
  void load(int v, const std::vector<Rgb>& x);   // all n patches, converted to T
  void store(int v, std::vector<Rgb>& x) const;  // patches [first, n) into x, which has n entries
  // Rows [first, n) of: y = a·x + c·ρ ⊙ (F x) + d·e (x is read whole), Σ x·y and Σ (x - y)² per channel,
  // y = a ⊙ x + b ⊙ y, y = x.
  void matvec(int y, int x, T a, T c, T d);
  Rgb dot(int x, int y) const;
  Rgb dist2(int x, int y) const;
  void axpby(int y, const Rgb& a, int x, const Rgb& b);
  void copy(int y, int x);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace radiosity
