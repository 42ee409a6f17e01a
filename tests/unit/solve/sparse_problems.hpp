// The sparse storages' tests' shared pieces (test_sparse.cpp, test_sparse_structure.cpp, test_sparse_file.cpp): a
// random problem with runs of zeros in F, the solve configurations, F held in a storage, and the system that reads it.
#pragma once
#include <random>
#include <string>

#include "radiosity/solve/solve.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"
#include "configs.hpp"
#include "reference.hpp"

namespace sparse_test {

using namespace radiosity;
using namespace solve_test;

// random_problem with about `zero_share` of F set to 0 in runs (occlusion hides neighbouring patches together).
inline Problem occluded_problem(size_t n, unsigned seed, double zero_share) {
  Problem p = random_problem(n, seed);
  std::mt19937_64 rng(seed + 7);
  std::uniform_real_distribution<double> u(0, 1);
  for (size_t i = 0; i < n; ++i)
    for (size_t j = 0; j < n;) {
      const size_t run = 1 + size_t(u(rng) * 12);
      const bool zero = u(rng) < zero_share;
      for (size_t r = 0; r < run && j < n; ++r, ++j)
        if (zero) p.F[i * n + j] = 0;
    }
  return p;
}

inline SolveConfig config(const std::string& backend, const std::string& layout, const std::string& precision, long steps,
                   int threads = 2, const std::string& method = "jacobi") {
  return solve_config(backend, layout, method, precision, steps, threads);
}

inline FormFactorMatrix stored(const Problem& p, FFStorage storage, FFValues values, uint32_t max_step = kMaxStep,
                        uint32_t merge_gap = kRunMergeGap, uint32_t max_length = kRunMaxLength) {
  FFMatrixOptions o;
  o.storage = storage;
  o.values = values;
  o.max_step = max_step;
  o.merge_gap = merge_gap;
  o.max_length = max_length;
  return FormFactorMatrix(p.F.data(), p.sys.n, p.sys.reflectivity, o);
}

inline System system_of(const Problem& p, const FormFactorMatrix& m) {
  System s = p.sys;
  s.matrix = m.view();
  return s;
}

}  // namespace sparse_test
