// The GPU backends' refusals: bad requests (everywhere: they come before the backend looks for a GPU), each GPU
// backend without a GPU, and each GPU factory given a system without F.
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
