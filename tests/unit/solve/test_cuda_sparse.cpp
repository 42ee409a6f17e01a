// The GPU backends on the sparse storages (cuda and cublas against serial's answer on the same stored values), and
// the storages they do not read, refused before any GPU is looked for.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "common/errors.hpp"
#include "radiosity/solve/contract/backends.hpp"
#include "radiosity/solve/methods/methods.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"
#include "configs.hpp"
#include "gpu_configs.hpp"
#include "reference.hpp"

using namespace radiosity;
using namespace solve_test;
using namespace cuda_test;

// The sparse storages on the GPU (sparse_device.cuh): cuSPARSE for csr float32 in float, our warp-per-row kernel for
// the rest, against backend serial on the same stored values (the same matrix object): other summation orders, so
// within 1e-6 relative in float (1e-12 in double), not bits. n = 300 with 70% zeros in runs gives rows of 0 to
// about 100 entries (partial chunks of 32); a row of reflectivity 0 is empty. The record names the product.
TEST(CudaSparse, SparseStoragesGiveSerialsAnswer) {
  SKIP_WITHOUT_GPU();
  Problem p = random_problem(300, 83);
  std::mt19937_64 rng(84);
  std::uniform_real_distribution<double> u(0, 1);
  for (float& f : p.F)
    if (u(rng) < 0.7) f = 0;
  p.sys.reflectivity[5] = {0, 0, 0};
  struct Stored {
    FFStorage storage;
    FFValues values;
  };
  for (const Stored st : {Stored{FFStorage::csr, FFValues::float32}, Stored{FFStorage::compressed, FFValues::float32},
                          Stored{FFStorage::compressed, FFValues::float16}, Stored{FFStorage::csr, FFValues::bfloat16}}) {
    FFMatrixOptions o;
    o.storage = st.storage;
    o.values = st.values;
    const FormFactorMatrix m(p.F.data(), p.sys.n, p.sys.reflectivity, o);
    System sys = p.sys;
    sys.matrix = m.view();
    for (const char* precision : {"float", "double"}) {
      SolveConfig ref = serial_double("jacobi", 30);
      ref.precision = parse_precision(precision);
      const SolveResult want = solve(sys, ref);
      for (const Gpu& g : {Gpu{"cuda", "cuda", "aos"}, Gpu{"cublas", "cublas", "soa"}}) {
        SCOPED_TRACE(g.label + " " + to_string(st.storage) + " " + to_string(st.values) + " " + precision);
        const SolveResult r = solve(sys, config(g, "jacobi", precision, 30));
        EXPECT_EQ(r.status, SolveStatus::steps_done);
        EXPECT_LE(max_rel(r.B, want.B), std::string(precision) == "float" ? 1e-6 : 1e-12);
        const bool by_cusparse = st.storage == FFStorage::csr && st.values == FFValues::float32 &&
                                 std::string(precision) == "float";
        EXPECT_EQ(contains(r.backend_info.at("product"), "cusparse"), by_cusparse) << r.backend_info.at("product");
        EXPECT_DOUBLE_EQ(r.matrix_bytes, double(m.view().row_start[p.sys.n]) *
                                                 (value_bytes(st.values) + (st.storage == FFStorage::csr ? 4 : 2)) +
                                             (by_cusparse ? 4.0 : 8.0) * double(p.sys.n + 1));
      }
    }
    // BiCG-STAB to a tolerance on the same storage
    const SolveResult b = solve(sys, config({"cuda", "cuda", "aos"}, "bicgstab", "double", 0));
    EXPECT_EQ(b.status, SolveStatus::converged);
  }
}

// Dense 16-bit F is read by the CPU backends only; hybrid reads dense float32 only. Refused before any GPU is
// looked for, so this runs everywhere.
TEST(CudaSparse, StoragesTheGpuBackendsDoNotReadAreRefused) {
  const Problem p = random_problem(20, 85);
  for (const auto& [storage, backend] : {std::pair{FFStorage::dense, "cuda"}, std::pair{FFStorage::dense, "cublas"},
                                         std::pair{FFStorage::csr, "hybrid"}}) {
    FFMatrixOptions o;
    o.storage = storage;
    o.values = storage == FFStorage::dense ? FFValues::float16 : FFValues::float32;
    const FormFactorMatrix m(p.F.data(), p.sys.n, p.sys.reflectivity, o);
    System sys = p.sys;
    sys.matrix = m.view();
    SolveConfig c;
    c.backend = backend;
    c.layout = std::string(backend) == "cublas" ? Layout::soa : Layout::aos;
    c.steps = 2;
    try {
      solve(sys, c);
      ADD_FAILURE() << backend << " accepted " << to_string(storage);
    } catch (const hpcgi::UsageError& e) {
      EXPECT_TRUE(contains(e.what(), "does not read") || contains(e.what(), "not available")) << e.what();
    }
  }
}
