// Backend `original`: RRV's radiosity step rebuilt as it was (report §3.5), the measured counterpart of the
// report's "Original" column. RRV keeps per patch a PatchCacheLine, a std::vector of (pointer to the neighbour's
// previous-step radiosity, form factor) pairs holding only form factors above a threshold; each step first copies
// radiosity to radiosityLast for every patch, then computes patch by patch
//   radiosity = reflectivity ⊙ Σ_pairs ff · *ptr + emission
// in float, RRV's Color. Fixed steps only (RRV has no tolerance), AOS only (RRV's Triangle is the record).
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "common/timer.hpp"
#include "radiosity/solve/contract/backends.hpp"
#include "radiosity/solve/methods/divergence.hpp"

namespace radiosity {
namespace {

struct Color {  // RRV's Color
  float r, g, b;
};

// RRV's Triangle: the vertices are never read here, but they set the 84-byte stride between the radiosityLast
// fields the cache lines point into, which is what the gather of the original loop pays for.
struct Triangle {
  float vertex[9];
  Color emission, reflectivity, radiosity, radiosityLast;
};

using PatchCacheLine = std::vector<std::pair<const Color*, float>>;

// RRV's PatchCacheLine::totalRadiosity.
Color total_radiosity(const PatchCacheLine& line) {
  Color sum{0, 0, 0};
  for (const auto& [ptr, ff] : line) {
    Color c = *ptr;
    c.r *= ff;
    c.g *= ff;
    c.b *= ff;
    sum.r += c.r;
    sum.g += c.g;
    sum.b += c.b;
  }
  return sum;
}

// RRV's RadiosityRenderer::computeStep.
void compute_step(std::vector<Triangle>& patch, const std::vector<PatchCacheLine>& cache) {
  const size_t n = patch.size();
  for (size_t i = 0; i < n; ++i) patch[i].radiosityLast = patch[i].radiosity;
  for (size_t i = 0; i < n; ++i) {
    Triangle& dest = patch[i];
    const Color sum = total_radiosity(cache[i]);
    dest.radiosity.r = sum.r * dest.reflectivity.r + dest.emission.r;
    dest.radiosity.g = sum.g * dest.reflectivity.g + dest.emission.g;
    dest.radiosity.b = sum.b * dest.reflectivity.b + dest.emission.b;
  }
}

Color to_color(const Rgb& x) { return {float(x[0]), float(x[1]), float(x[2])}; }

// ‖radiosity - radiosityLast‖₂ / scale per channel: the relative residual of the previous step, as Jacobi
// measures it.
Rgb step_residual(const std::vector<Triangle>& patch, const Rgb& scale) {
  Rgb d2{0, 0, 0};
  for (const Triangle& t : patch) {
    const double dr = t.radiosity.r - t.radiosityLast.r, dg = t.radiosity.g - t.radiosityLast.g,
                 db = t.radiosity.b - t.radiosityLast.b;
    d2[0] += dr * dr;
    d2[1] += dg * dg;
    d2[2] += db * db;
  }
  return {std::sqrt(d2[0]) / scale[0], std::sqrt(d2[1]) / scale[1], std::sqrt(d2[2]) / scale[2]};
}

void download(const std::vector<Triangle>& patch, std::vector<Rgb>& B) {
  B.resize(patch.size());
  for (size_t i = 0; i < patch.size(); ++i) B[i] = {patch[i].radiosity.r, patch[i].radiosity.g, patch[i].radiosity.b};
}

}  // namespace

SolveResult run_original(const System& sys, const SolveConfig& cfg, const IterationCallback& callback) {
  SolveResult res;
  hpcgi::Timer t;
  const size_t n = sys.n;
  std::vector<Triangle> patch(n);
  for (size_t i = 0; i < n; ++i) {
    patch[i].emission = to_color(sys.emission[i]);
    patch[i].reflectivity = to_color(sys.reflectivity[i]);
    patch[i].radiosity = to_color(sys.initial[i]);
  }
  // RRV fills a cache line from the hemicube's map, in increasing patch index; here from row i of F.
  std::vector<PatchCacheLine> cache(n);
  size_t pairs = 0;
  for (size_t i = 0; i < n; ++i) {
    const float* Fi = dense_float32(sys) + i * n;
    for (size_t j = 0; j < n; ++j)
      if (Fi[j] > cfg.ff_threshold) cache[i].emplace_back(&patch[j].radiosityLast, Fi[j]);
    pairs += cache[i].size();
  }
  res.matrix_bytes = double(pairs) * sizeof(PatchCacheLine::value_type);
  res.setup_s = t.seconds();

  t.reset();
  double callback_s = 0;
  res.status = SolveStatus::steps_done;
  const Rgb scale = residual_scale(sys);
  Rgb first{0, 0, 0};
  for (long step = 1; step <= cfg.steps; ++step) {
    compute_step(patch, cache);
    res.iterations = step;
    // RRV never looks. Each step is checked here (O(n) beside the step's O(pairs)), so that a run that went wrong
    // stops at once like the other backends, instead of finishing its steps on NaN or ever larger numbers.
    const Rgb d = step_residual(patch, scale);
    if (step == 1) first = d;
    if (!std::isfinite(d[0]) || !std::isfinite(d[1]) || !std::isfinite(d[2])) {
      res.status = SolveStatus::nonfinite;
      res.detail = "original: non-finite radiosity at step " + std::to_string(step);
      break;
    }
    if (const std::string why = divergence(first, d); !why.empty()) {
      res.status = SolveStatus::divergent;
      res.detail = "original: " + why + " at step " + std::to_string(step);
      break;
    }
    if (callback) {
      hpcgi::Timer tc;
      download(patch, res.B);
      callback(step, res.B);
      callback_s += tc.seconds();
    }
  }
  res.matrix_passes = res.iterations;
  res.solve_s = t.seconds() - callback_s;

  t.reset();
  download(patch, res.B);
  res.rel_residual = relative_residual(sys, res.B);
  res.check_s = t.seconds();
  return res;
}

}  // namespace radiosity
