// The GPU backends (cuda, cublas with and without fused, hybrid) against the serial float64 result, operation by
// operation and through the shared methods; cuda and cublas on the sparse storages against serial's; the hybrid's ends against the pure backends bit for bit; the split of
// the time and the bytes; and the refusals. A test that needs a GPU is skipped, with the reason, where there is
// none; the refusals that need none run everywhere.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "common/errors.hpp"
#include "radiosity/solve/backends.hpp"
#include "radiosity/solve/methods/methods.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"
#include "configs.hpp"
#include "reference.hpp"

using namespace radiosity;
using namespace solve_test;

namespace {

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// Why a GPU backend cannot run here (the backend's own refusal: no GPU, or a build without CUDA), or "" when it can.
const std::string& gpu_absent() {
  static const std::string why = [] {
    const Problem p = random_problem(8, 1);
    SolveConfig c;
    c.backend = "cuda";
    c.steps = 1;
    try {
      solve(p.sys, c);
      return std::string();
    } catch (const hpcgi::UsageError& e) {
      const std::string what = e.what();
      return contains(what, "needs an NVIDIA GPU") || contains(what, "is not available") ? what : std::string();
    }
  }();
  return why;
}
#define SKIP_WITHOUT_GPU()                                                          \
  do {                                                                              \
    if (!gpu_absent().empty()) GTEST_SKIP() << "the GPU backends cannot run here: " << gpu_absent(); \
  } while (0)

// A GPU configuration as the registry runs it.
struct Gpu {
  std::string label, backend, layout;
  bool fused = false;
  double distribution = 0.5;
  bool overlap = false;
};
const std::vector<Gpu>& every_gpu_config() {
  static const std::vector<Gpu> all = {
      {"cuda", "cuda", "aos"},
      {"cublas", "cublas", "soa"},
      {"cublas fused", "cublas", "soa", true},
      {"hybrid d=0", "hybrid", "aos", false, 0.0},
      {"hybrid d=0.3", "hybrid", "aos", false, 0.3},
      {"hybrid d=0.3 overlap", "hybrid", "aos", false, 0.3, true},
      {"hybrid d=1", "hybrid", "aos", false, 1.0},
  };
  return all;
}

SolveConfig config(const Gpu& g, const std::string& method, const std::string& precision, long steps) {
  SolveConfig c = solve_config(g.backend, g.layout, method, precision, steps);
  c.tol = 1e-6;
  c.fused = g.fused;
  c.distribution = g.distribution;
  c.overlap = g.overlap;
  c.max_iter = 5000;
  return c;
}

SolveConfig serial_double(const std::string& method, long steps) {
  SolveConfig c = solve_config("serial", "aos", method, "double", steps);
  c.max_iter = 10000;
  return c;
}

double bound(const std::string& precision) { return precision == "float" ? 1e-5 : 1e-12; }

#ifdef HAVE_CUDA
std::vector<Rgb> random_vector(size_t n, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Rgb> v(n);
  for (Rgb& x : v)
    for (double& c : x) c = u(rng);
  return v;
}
#endif

// max |x - y| over max |y|.
double max_rel(const std::vector<Rgb>& x, const std::vector<Rgb>& y) {
  double num = 0, den = 0;
  for (size_t i = 0; i < y.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      num = std::max(num, std::abs(x[i][c] - y[i][c]));
      den = std::max(den, std::abs(y[i][c]));
    }
  return num / den;
}

}  // namespace

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

// The refusals that need no GPU: they come before the backend looks for one.
TEST(CudaRefusals, BadRequestsAreUsageErrors) {
  const Problem p = random_problem(10, 95);
  auto refused = [&](const SolveConfig& c, const std::string& words) {
    try {
      solve(p.sys, c);
      ADD_FAILURE() << "accepted: " << words;
    } catch (const hpcgi::UsageError& e) {
      EXPECT_TRUE(contains(e.what(), words)) << e.what();
    }
  };
#ifdef HAVE_CUDA
  Gpu h{"hybrid", "hybrid", "aos"};
  refused(config(h, "bicgstab", "float", 0), "backend 'hybrid' does not run method 'bicgstab'");
  for (double d : {1.5, -0.1, std::numeric_limits<double>::quiet_NaN()}) {
    h.distribution = d;
    refused(config(h, "jacobi", "float", 4), "distribution must be in [0, 1]");
  }
  refused(config({"", "cuda", "aos", true}, "jacobi", "float", 4), "fused applies to backend cublas");
  refused(config({"", "hybrid", "aos", true}, "jacobi", "float", 4), "fused applies to backend cublas");
  refused(config({"", "cublas", "aos"}, "jacobi", "float", 4), "does not run layout 'aos'");
  refused(config({"", "cuda", "soa"}, "jacobi", "float", 4), "does not run layout 'soa'");
#else
  for (const char* b : {"cuda", "cublas", "hybrid"}) refused(config({"", b, "aos"}, "jacobi", "float", 4), "not available");
#endif
}

TEST(CudaRefusals, WithoutAGpuEachGpuBackendSaysSo) {
  if (gpu_absent().empty()) GTEST_SKIP() << "a GPU is present: this test checks the refusal where there is none";
#ifndef HAVE_CUDA
  GTEST_SKIP() << "built without CUDA: " << gpu_absent();
#endif
  const Problem p = random_problem(10, 97);
  for (const Gpu& g : every_gpu_config()) {
    SCOPED_TRACE(g.label);
    try {
      solve(p.sys, config(g, "jacobi", "float", 4));
      ADD_FAILURE() << "accepted";
    } catch (const hpcgi::UsageError& e) {
      EXPECT_TRUE(contains(e.what(), "needs an NVIDIA GPU")) << e.what();
      EXPECT_TRUE(contains(e.what(), "backend " + g.backend)) << e.what();
    }
  }
}

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

// A system with neither dense F nor a stored matrix is refused by each GPU factory itself (defence behind the
// registry's storage check above): one clear UsageError, never a null F read on the device. Needs a GPU: the
// factories look for one first.
TEST(CudaRefusals, EachGpuFactoryRefusesASystemWithoutF) {
  SKIP_WITHOUT_GPU();
#ifdef HAVE_CUDA
  System sys = random_problem(10, 99).sys;
  sys.matrix.data = nullptr;  // a dense matrix without its values
  for (const Gpu& g : every_gpu_config()) {
    SCOPED_TRACE(g.label);
    const SolveConfig c = config(g, "jacobi", "float", 4);
    try {
      if (g.backend == "cuda") make_cuda<float>(sys, c, 4);
      else if (g.backend == "cublas") make_cublas<float>(sys, c, 4);
      else make_hybrid<float>(sys, c, 4);
      ADD_FAILURE() << "accepted a system without F";
    } catch (const hpcgi::UsageError& e) {
      EXPECT_TRUE(contains(e.what(), "dense form factors are read as the file's float32 values")) << e.what();
    }
  }
#endif
}
