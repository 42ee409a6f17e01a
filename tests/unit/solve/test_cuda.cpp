// The GPU backends (cuda, cublas with and without fused, hybrid) against the serial float64 result, operation by
// operation and through the shared methods; the hybrid's ends against the pure backends bit for bit; the split of the
// time and the bytes; what cublas says it reads; form factors too large for the GPU. The sparse storages on the GPU
// are test_cuda_sparse.cpp's, the refusals test_cuda_refusals.cpp's. A test that needs a GPU is skipped, with the
// reason, where there is none.
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

// 32 Jacobi steps as the report; n = 37 leaves a block and a tile part empty, 300 spans two tiles of x.
TEST(CudaBackends, FixedJacobiStepsAgreeWithSerialFloat64) {
  SKIP_WITHOUT_GPU();
  for (size_t n : {37, 300}) {
    const Problem p = random_problem(n, 81);
    const SolveResult ref = solve(p.sys, serial_double("jacobi", 32));
    for (const Gpu& g : every_gpu_config())
      for (const char* precision : {"float", "double"}) {
        SCOPED_TRACE(g.label + " " + precision + " n " + std::to_string(n));
        const SolveResult r = solve(p.sys, config(g, "jacobi", precision, 32));
        EXPECT_EQ(r.status, SolveStatus::steps_done);
        EXPECT_EQ(r.iterations, 32);
        EXPECT_LE(rel_diff(r.B, ref.B), bound(precision));
        EXPECT_LE(max_rel(r.B, ref.B), 10 * bound(precision));
        EXPECT_FALSE(r.backend_info.at("gpu").empty());
        EXPECT_GT(r.device_compute_s + r.host_compute_s, 0);
      }
  }
}

// Stopping on a tolerance: ρ < 0.5, so ‖b - b*‖/‖b*‖ ≤ 3 × the residual: tol 1e-6 in float leaves 1e-5.
TEST(CudaBackends, ToleranceRunsConvergeToTheDirectSolution) {
  SKIP_WITHOUT_GPU();
  const Problem p = random_problem(200, 83, 0.0, 0.5);
  const std::vector<Rgb> exact = direct_solve(p.sys);
  for (const Gpu& g : every_gpu_config())
    for (const char* method : {"jacobi", "bicgstab"})
      for (const char* precision : {"float", "double"}) {
        if (g.backend == "hybrid" && std::string(method) == "bicgstab") continue;  // Jacobi only (refusal below)
        SCOPED_TRACE(g.label + " " + method + " " + precision);
        SolveConfig c = config(g, method, precision, 0);
        c.tol = std::string(precision) == "float" ? 1e-6 : 1e-11;
        const SolveResult r = solve(p.sys, c);
        EXPECT_EQ(r.status, SolveStatus::converged) << r.detail;
        EXPECT_LE(rel_diff(r.B, exact), bound(precision));
      }
}

// Every operation of the Kernels contract, also those Jacobi does not use (hybrid's axpby and copy leave the
// halves apart; the next product must exchange them first), against the serial kernels.
TEST(CudaBackends, EveryKernelAgreesWithSerial) {
  SKIP_WITHOUT_GPU();
#ifdef HAVE_CUDA
  const size_t n = 300;
  const Problem p = random_problem(n, 87);
  const std::vector<Rgb> x = random_vector(n, 5), y = random_vector(n, 6);
  auto check = [&](auto make, auto tag, const Gpu& g, double tol) {
    using T = decltype(tag);
    SCOPED_TRACE(g.label + (sizeof(T) == 4 ? " float" : " double"));
    const SolveConfig c = config(g, "jacobi", sizeof(T) == 4 ? "float" : "double", 0);
    const std::unique_ptr<Kernels<T>> k = make(p.sys, c, 4);
    SolveConfig sc = c;
    sc.layout = Layout::aos;
    const std::unique_ptr<Kernels<T>> s = make_serial<T>(p.sys, sc, 4);
    std::vector<Rgb> got, want;
    auto same = [&](int v, const char* what) {
      k->download(v, got);
      s->download(v, want);
      EXPECT_LE(max_rel(got, want), tol) << what;
    };
    for (Kernels<T>* q : {k.get(), s.get()}) {
      q->upload(0, x);
      q->upload(1, y);
    }
    same(0, "upload/download");
    for (Kernels<T>* q : {k.get(), s.get()}) q->matvec(2, 0, 0.5, -0.7, 1.3);
    same(2, "matvec");
    const Rgb dk = k->dot(0, 1), ds = s->dot(0, 1), ek = k->dist2(0, 1), es = s->dist2(0, 1);
    for (int ch = 0; ch < 3; ++ch) {
      EXPECT_NEAR(dk[ch], ds[ch], tol * double(n)) << "dot";
      EXPECT_NEAR(ek[ch], es[ch], tol * es[ch]) << "dist2";
    }
    const Rgb a{0.25, -1.5, 2}, b{1, 0.5, -0.75};
    for (Kernels<T>* q : {k.get(), s.get()}) q->axpby(1, a, 0, b);
    same(1, "axpby");
    for (Kernels<T>* q : {k.get(), s.get()}) q->matvec(3, 1, 1, -1, 0);
    same(3, "matvec after axpby");
    for (Kernels<T>* q : {k.get(), s.get()}) q->copy(2, 1);
    same(2, "copy");
    for (Kernels<T>* q : {k.get(), s.get()}) q->matvec(3, 2, 0, 1, 1);
    same(3, "matvec after copy");
    EXPECT_EQ(k->matrix_bytes() > 0, true);
  };
  for (const Gpu& g : every_gpu_config()) {
    auto run = [&](auto tag, double tol) {
      using T = decltype(tag);
      const auto make = g.backend == "cuda" ? make_cuda<T> : g.backend == "cublas" ? make_cublas<T> : make_hybrid<T>;
      check(make, tag, g, tol);
    };
    run(float{}, 1e-5);
    run(double{}, 1e-13);
  }
#endif
}

// d = 0 is backend openmp and d = 1 backend cuda, bit for bit; overlapping the copies changes no bit.
TEST(CudaBackends, HybridEndsAreThePureBackendsBitForBit) {
  SKIP_WITHOUT_GPU();
  for (size_t n : {37, 300}) {
    const Problem p = random_problem(n, 89);
    for (const char* precision : {"float", "double"}) {
      SCOPED_TRACE(std::string(precision) + " n " + std::to_string(n));
      Gpu openmp{"openmp", "openmp", "aos"}, cuda{"cuda", "cuda", "aos"}, hybrid{"hybrid", "hybrid", "aos"};
      hybrid.distribution = 0;
      EXPECT_EQ(solve(p.sys, config(hybrid, "jacobi", precision, 32)).B,
                solve(p.sys, config(openmp, "jacobi", precision, 32)).B);
      hybrid.distribution = 1;
      EXPECT_EQ(solve(p.sys, config(hybrid, "jacobi", precision, 32)).B,
                solve(p.sys, config(cuda, "jacobi", precision, 32)).B);
      hybrid.distribution = 0.3;
      const SolveResult plain = solve(p.sys, config(hybrid, "jacobi", precision, 32));
      hybrid.overlap = true;
      EXPECT_EQ(solve(p.sys, config(hybrid, "jacobi", precision, 32)).B, plain.B);
    }
  }
}

// Each step moves the halves (3 n values) and the three sums of dist2 (3 doubles); the ends move no halves, and
// at d = 0 the GPU adds nothing either.
TEST(CudaBackends, HybridMovesTheHalvesAndSplitsItsTime) {
  SKIP_WITHOUT_GPU();
  const size_t n = 300;
  const long steps = 8;
  const Problem p = random_problem(n, 91);
  for (bool overlap : {false, true}) {
    SCOPED_TRACE(overlap ? "overlap" : "blocking");
    Gpu h{"hybrid", "hybrid", "aos", false, 0.3, overlap};
    SolveResult r = solve(p.sys, config(h, "jacobi", "float", steps));
    EXPECT_EQ(r.backend_info.at("gpu_rows"), "90");
    EXPECT_EQ(r.backend_info.at("cpu_rows"), "210");
    EXPECT_EQ(r.transfer_bytes, double(steps) * (3.0 * n * sizeof(float) + 3 * sizeof(double)));
    EXPECT_GT(r.transfer_s, 0);
    EXPECT_GT(r.device_compute_s, 0);
    EXPECT_GT(r.host_compute_s, 0);
    EXPECT_GT(r.upload_s, 0);
    EXPECT_EQ(r.matrix_bytes, 4.0 * n * n);
    h.distribution = 1;
    r = solve(p.sys, config(h, "jacobi", "double", steps));
    EXPECT_EQ(r.transfer_bytes, double(steps) * 3 * sizeof(double));
    EXPECT_EQ(r.host_compute_s >= 0, true);
    h.distribution = 0;
    r = solve(p.sys, config(h, "jacobi", "double", steps));
    EXPECT_EQ(r.transfer_bytes, 0);
    EXPECT_EQ(r.device_compute_s, 0);
    EXPECT_EQ(r.backend_info.at("gpu_rows"), "0");
  }
}

// cuBLAS: Sgemv per channel reads F three times, the fused Sgemm once; double reads F widened to 8 bytes.
TEST(CudaBackends, CublasSaysWhatItReads) {
  SKIP_WITHOUT_GPU();
  const size_t n = 64;
  const Problem p = random_problem(n, 93);
  const double nn = double(n) * n;
  EXPECT_EQ(solve(p.sys, config({"", "cublas", "soa"}, "jacobi", "float", 2)).matrix_bytes, 12 * nn);
  EXPECT_EQ(solve(p.sys, config({"", "cublas", "soa", true}, "jacobi", "float", 2)).matrix_bytes, 4 * nn);
  EXPECT_EQ(solve(p.sys, config({"", "cublas", "soa", true}, "jacobi", "double", 2)).matrix_bytes, 8 * nn);
  EXPECT_EQ(solve(p.sys, config({"", "cuda", "aos"}, "jacobi", "double", 2)).matrix_bytes, 4 * nn);
}

// A scene whose F does not fit is refused before anything is allocated or read (F here is 8 floats, far too few
// for its n: reading it would fault, which is the point: the refusal comes first).
TEST(CudaBackends, FormFactorsThatDoNotFitAreRefusedBeforeAllocating) {
  SKIP_WITHOUT_GPU();
  const size_t n = 300000;  // 360 GB of F
  std::vector<float> F(8, 0.0f);
  System s;
  s.n = n;
  s.matrix = dense_float32_view(F.data(), s.n);
  s.emission.assign(n, Rgb{1, 1, 1});
  s.reflectivity.assign(n, Rgb{0.5, 0.5, 0.5});
  s.initial = s.emission;
  for (const Gpu& g : every_gpu_config()) {
    if (g.backend == "hybrid" && g.distribution < 1) continue;  // a share of F could fit a big GPU, and then be read
    SCOPED_TRACE(g.label);
    try {
      solve(s, config(g, "jacobi", "float", 1));
      ADD_FAILURE() << "accepted";
    } catch (const hpcgi::UsageError& e) {
      EXPECT_TRUE(contains(e.what(), "GiB of GPU memory")) << e.what();
    }
  }
}
