#include "radiosity/relight/basis.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <optional>

#include "common/errors.hpp"
#include "common/timer.hpp"
#include "radiosity/solve/host/exec.hpp"
#include "radiosity/solve/host/linalg.hpp"

namespace radiosity::relight {

void LightBasis::pack() {
  packed.assign(B.size() * 3 * n, 0.0f);
  for (size_t l = 0; l < B.size(); ++l)
    for (size_t j = 0; j < 3 * n; ++j) packed[l * 3 * n + j] = float(B[l][j]);
}

LightBasis solve_light_basis(const Mesh& m, const FFMatrixView& F, const std::vector<NamedEntity>& lights,
                             const BasisOptions& opt) {
  hpcgi::Timer t;
  const size_t n = m.size(), k = lights.size();
  if (k == 0) throw hpcgi::UsageError("the scene has no lights (no entity emits): there is nothing to relight");
  const OpenMPExec ex(opt.threads);
  std::vector<Rgb> rho_host(n);
  for (size_t i = 0; i < n; ++i) rho_host[i] = m.patches[i].reflectivity;
  Soa<double> rho(n);
  load(ex, rho, rho_host);
  std::vector<Soa<double>> E, X, Y;
  std::vector<Rgb> scale(k);
  for (size_t l = 0; l < k; ++l) {
    std::vector<Rgb> e(n, Rgb{0, 0, 0});
    for (size_t i : lights[l].patches) e[i] = m.patches[i].emission;
    for (int c = 0; c < 3; ++c) {
      double s = 0;
      for (const Rgb& v : e) s += v[c] * v[c];
      scale[l][c] = s > 0 ? std::sqrt(s) : 1.0;
    }
    E.emplace_back(n), X.emplace_back(n), Y.emplace_back(n);
    load(ex, E.back(), e);
    load(ex, X.back(), e);  // B_0 = E_l
    load(ex, Y.back(), e);
  }
  const std::vector<int32_t> rows = dense_rows_to_compute(rho_host);
  // Several lights: F's row blocks, every light's product in one pass over them; one light: F as it is stored.
  std::optional<RowBlockMatrix> blocks;
  if (k > 1) blocks.emplace(F, rows, ex.threads());
  LightBasis basis;
  basis.n = n;
  basis.tol = opt.tol;
  for (long step = 1;; ++step) {
    if (blocks)  // Y = E + ρ ⊙ F X
      multi_affine_matvec<OpenMPExec, double>(ex, *blocks, X, Y, rho, E, 0.0, 1.0, 1.0);
    else
      affine_matvec(ex, F, rows, X[0], Y[0], rho, E[0], 0.0, 1.0, 1.0);
    // Y - X = E - A X: the residual of X, which is the answer once every light's is <= tol.
    double worst = 0;
    for (size_t l = 0; l < k; ++l) {
      const Rgb d2 = dist2(ex, X[l], Y[l]);
      for (int c = 0; c < 3; ++c) {
        const double r = std::sqrt(d2[c]) / scale[l][c];
        worst = std::isnan(r) ? r : std::max(worst, r);
      }
    }
    if (!std::isfinite(worst))
      throw hpcgi::NumericalError("light basis: non-finite radiosity at Jacobi step " + std::to_string(step));
    if (worst <= opt.tol) {
      basis.iterations = step - 1;
      basis.max_residual = worst;
      break;
    }
    if (step > opt.max_iter)
      throw hpcgi::NumericalError("light basis: relative residual " + std::to_string(worst) + " after " +
                                  std::to_string(opt.max_iter) + " Jacobi steps, not " + std::to_string(opt.tol));
    std::swap(X, Y);
  }
  for (size_t l = 0; l < k; ++l) {
    basis.lights.push_back(lights[l].name);
    std::vector<Rgb> b;
    store(ex, X[l], b);
    std::vector<double>& flat = basis.B.emplace_back(3 * n);
    for (size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) flat[3 * i + c] = b[i][c];
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
  const OpenMPExec ex(threads);  // a frame is tens of microseconds: 1 thread, where other work shares the cores
  const size_t blocks = (len + 23) / 24;
  ex.rows(blocks, [&](size_t b0, size_t b1) {
    const size_t j0 = 24 * b0, j1 = std::min(len, 24 * b1);
    for (size_t j = j0; j < j1; j += 24) {
      const size_t m = std::min<size_t>(24, j1 - j);
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
  });
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
