#include "radiosity/relight/basis.hpp"

#include <algorithm>
#include <cmath>

#include "common/errors.hpp"
#include "common/timer.hpp"
#include "radiosity/solve/multi_solve.hpp"

namespace radiosity::relight {

void LightBasis::pack() {
  packed.assign(B.size() * 3 * n, 0.0f);
  for (size_t l = 0; l < B.size(); ++l)
    for (size_t j = 0; j < 3 * n; ++j) packed[l * 3 * n + j] = float(B[l][j]);
}

SolveConfig basis_config(const BasisOptions& opt) {
  SolveConfig cfg;  // Jacobi in float64, every light's every channel to opt.tol, B_0 = E_l
  cfg.method = Method::jacobi;
  cfg.precision = Precision::double_;
  cfg.backend = opt.backend;
  cfg.tol = opt.tol;
  cfg.max_iter = opt.max_iter;
  cfg.threads = opt.threads;
  return cfg;
}

LightBasis solve_light_basis(const Mesh& m, const FFMatrixView& F, const std::vector<NamedEntity>& lights,
                             const BasisOptions& opt) {
  hpcgi::Timer t;
  const size_t n = m.size(), k = lights.size();
  if (k == 0) throw hpcgi::UsageError("the scene has no lights (no entity emits): there is nothing to relight");
  std::vector<std::vector<Rgb>> E;
  for (size_t l = 0; l < k; ++l) {
    std::vector<Rgb>& e = E.emplace_back(n, Rgb{0, 0, 0});
    for (size_t i : lights[l].patches) e[i] = m.patches[i].emission;
  }
  const MultiSolveResult r = solve_multi(make_system(m, F), E, basis_config(opt));
  // Every rank of backend mpi reaches the same status (its residuals are summed over the ranks): agreed, so that
  // rank 0 alone reports it.
  using Failed = hpcgi::Agreed<hpcgi::NumericalError>;
  if (r.status == SolveStatus::nonfinite) throw Failed("light basis: " + r.detail);
  if (failed(r.status)) throw Failed("light basis: " + std::string(to_string(r.status)) + ": " + r.detail);
  if (r.status != SolveStatus::converged)
    throw Failed("light basis: relative residual " + std::to_string(r.max_residual) + " after " +
                 std::to_string(opt.max_iter) + " Jacobi steps, not " + std::to_string(opt.tol));
  LightBasis basis;
  basis.n = n;
  basis.tol = opt.tol;
  basis.iterations = r.iterations;
  basis.max_residual = r.max_residual;
  for (size_t l = 0; l < k; ++l) {
    basis.lights.push_back(lights[l].name);
    std::vector<double>& flat = basis.B.emplace_back(3 * n);
    for (size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) flat[3 * i + c] = r.B[l][i][c];
  }
  basis.pack();
  basis.seconds = t.seconds();
  return basis;
}

void mix(const LightBasis& basis, const std::vector<LightSetting>& settings, std::vector<float>& out, int threads) {
  const size_t n = basis.n, k = basis.lights.size(), len = 3 * n;
  out.resize(len);
  // The weights of light l repeated over 24 floats (8 patches' r, g, b), so that the inner loop is a plain
  // multiply-add over consecutive floats.
  std::vector<float> w(24 * k);
  for (size_t l = 0; l < k; ++l)
    for (size_t j = 0; j < 24; ++j) w[24 * l + j] = float(settings[l].intensity * settings[l].colour[j % 3]);
  const float* P = basis.packed.data();
  float* o = out.data();
  // a frame is tens of microseconds: 1 thread, where other work shares the cores. Each block of 24 floats is its
  // own sums, whichever thread takes it.
  const long blocks = long((len + 23) / 24);
#pragma omp parallel for num_threads(solver_threads(threads)) schedule(static)
  for (long b = 0; b < blocks; ++b) {
    const size_t j = 24 * size_t(b);
    const size_t m = std::min<size_t>(24, len - j);
    float acc[24] = {};
    for (size_t l = 0; l < k; ++l) {
      const float* p = P + l * len + j;
      const float* wl = w.data() + 24 * l;
      if (m == 24) {
#pragma omp simd
        for (size_t q = 0; q < 24; ++q) acc[q] += wl[q] * p[q];
      } else {
        for (size_t q = 0; q < m; ++q) acc[q] += wl[q] * p[q];
      }
    }
    for (size_t q = 0; q < m; ++q) o[j + q] = acc[q];
  }
}

std::vector<Rgb> frame_emission(const Mesh& m, const std::vector<NamedEntity>& lights,
                                const std::vector<LightSetting>& settings) {
  std::vector<Rgb> e(m.size());
  for (size_t i = 0; i < m.size(); ++i) e[i] = m.patches[i].emission;
  for (size_t l = 0; l < lights.size(); ++l)
    for (size_t i : lights[l].patches)
      for (int c = 0; c < 3; ++c) e[i][c] = settings[l].intensity * settings[l].colour[c] * m.patches[i].emission[c];
  return e;
}

}  // namespace radiosity::relight
