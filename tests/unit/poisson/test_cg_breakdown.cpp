// CG's guards, on a matrix the Poisson problem never gives: a small dense one behind the backend contract, so
// that an indefinite or NaN matrix makes p·Ap non-positive or not finite. Both variants must stop at once with
// status breakdown and say what broke (bin/poisson turns that into exit status 3, common/cli.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "poisson/methods/cg.hpp"
#include "poisson/contract/kernels.hpp"

namespace {

// CG's kernels on a dense m×m matrix A and right-hand side b, in double, plainly.
class DenseKernels : public poisson::OneSweepKernels<double> {
 public:
  DenseKernels(std::vector<double> A, std::vector<double> b) : A_(std::move(A)), b_(std::move(b)), m_(b_.size()) {}
  double init() override {
    x_.assign(m_, 0.0);
    r_ = p_ = b_;
    return dot(r_, r_);
  }
  double calc_w() override {
    w_ = apply(p_);
    return dot(p_, w_);
  }
  double calc_ur(double alpha) override {
    for (size_t i = 0; i < m_; ++i) {
      x_[i] += alpha * p_[i];
      r_[i] -= alpha * w_[i];
    }
    return dot(r_, r_);
  }
  void calc_p(double beta) override {
    for (size_t i = 0; i < m_; ++i) p_[i] = r_[i] + beta * p_[i];
  }
  double r_Ar() override { return dot(r_, apply(r_)); }
  poisson::SweepDots sweep(double alpha, double beta) override {
    calc_p(beta);
    w_ = apply(p_);
    calc_ur(alpha);
    return {dot(r_, r_), r_Ar()};
  }
  double true_residual2() override {
    const std::vector<double> ax = apply(x_);
    double s = 0;
    for (size_t i = 0; i < m_; ++i) s += (b_[i] - ax[i]) * (b_[i] - ax[i]);
    return s;
  }
  double error_inf() override { return 0; }
  std::vector<double> solution() override { return x_; }
  int vectors_per_iteration() const override { return 0; }
  std::map<std::string, std::string> info() const override { return {}; }
  poisson::OneSweepKernels<double>* one_sweep() override { return this; }

 private:
  std::vector<double> apply(const std::vector<double>& v) const {
    std::vector<double> out(m_, 0.0);
    for (size_t i = 0; i < m_; ++i)
      for (size_t j = 0; j < m_; ++j) out[i] += A_[i * m_ + j] * v[j];
    return out;
  }
  static double dot(const std::vector<double>& a, const std::vector<double>& b) {
    double s = 0;
    for (size_t i = 0; i < a.size(); ++i) s += a[i] * b[i];
    return s;
  }
  std::vector<double> A_, b_, x_, r_, p_, w_;
  size_t m_;
};

poisson::CgResult run(const std::string& variant, std::vector<double> A, std::vector<double> b) {
  DenseKernels k(std::move(A), std::move(b));
  return poisson::run_variant<double>(k, poisson::parse_variant(variant), 1e-12, 1000);
}

}  // namespace

// The fake is right: on an SPD diagonal matrix with two distinct eigenvalues CG converges in two iterations.
TEST(CgBreakdown, DenseKernelsConvergeOnSpd) {
  for (const char* variant : {"classic", "onesweep"}) {
    const poisson::CgResult r = run(variant, {1, 0, 0, 2}, {1, 1});
    EXPECT_EQ(r.status, poisson::Status::converged) << variant;
    EXPECT_EQ(r.iterations, 2) << variant;
  }
}

// diag(1, -1) and b = (1, 1): p·Ap = 1 - 1 = 0 at the first iteration; diag(1, -3): -2.
TEST(CgBreakdown, IndefiniteMatrixStopsAtOnce) {
  for (const char* variant : {"classic", "onesweep"}) {
    SCOPED_TRACE(variant);
    poisson::CgResult r = run(variant, {1, 0, 0, -1}, {1, 1});
    EXPECT_EQ(r.status, poisson::Status::breakdown);
    EXPECT_EQ(r.iterations, 0);
    EXPECT_NE(r.breakdown.find("p·Ap = 0.000000 at iteration 1"), std::string::npos) << r.breakdown;
    r = run(variant, {1, 0, 0, -3}, {1, 1});
    EXPECT_EQ(r.status, poisson::Status::breakdown);
    EXPECT_NE(r.breakdown.find("p·Ap = -2.000000 at iteration 1"), std::string::npos) << r.breakdown;
  }
}

// diag(1, -1/2) with b = (1, 1): p·Ap = 1/2 > 0 at iteration 1, so CG takes a step, and the next direction has
// p·Ap < 0: the check holds after the first iteration as well.
TEST(CgBreakdown, IndefiniteMatrixStopsLaterToo) {
  for (const char* variant : {"classic", "onesweep"}) {
    const poisson::CgResult r = run(variant, {1, 0, 0, -0.5}, {1, 1});
    EXPECT_EQ(r.status, poisson::Status::breakdown) << variant;
    EXPECT_EQ(r.iterations, 1) << variant;
    EXPECT_NE(r.breakdown.find("at iteration 2"), std::string::npos) << r.breakdown;
  }
}

TEST(CgBreakdown, NanStopsAtOnce) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const char* variant : {"classic", "onesweep"}) {
    const poisson::CgResult r = run(variant, {1, 0, 0, nan}, {1, 1});
    EXPECT_EQ(r.status, poisson::Status::breakdown) << variant;
    EXPECT_NE(r.breakdown.find("p·Ap = nan"), std::string::npos) << r.breakdown;
  }
}
