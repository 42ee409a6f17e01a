#include "radiosity/formfactor/hemicube.hpp"

#include <omp.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <utility>

#include "common/errors.hpp"
#include "radiosity/formfactor/hemicube_raster.hpp"
#include "radiosity/formfactor/hemicube_weights.hpp"

namespace radiosity {
namespace {

using namespace hemicube;

// RRV's gluPerspective(90, 1, 1e-3, 50).
constexpr double kRrvNear = 1e-3;
constexpr double kRrvFar = 50;
// With exact weights nothing should be lost to the near plane: a plane this close to the centroid (relative to the
// patch's size) cuts away only geometry that pierces the patch itself. The far plane is dropped.
constexpr double kExactNearPerSize = 1e-6;
// hemicube_row_work's cost model, in nanoseconds on one core: transforming a patch into the row's frame; clipping
// and rasterising a patch in front of the row's patch (more pixels to fill at a finer hemicube: a + b·R); clearing
// and gathering one pixel. Fitted to single rows timed on this project's 2-core development machine (scene1, scene2
// at R = 32, 128, 256, room3 at R = 64: per row, const + per-front-patch cost explains the time within 12-18% rms);
// only their ratios matter for a split.
constexpr double kWorkPerPatchNs = 25;
constexpr double kWorkPerFrontPatchNs = 50, kWorkPerFrontPatchPerRNs = 0.5;
constexpr double kWorkPerPixelNs = 1.5;
// Which face of the hemicube sees the point at local coordinates (lu, lv, ln): the one across which the largest of
// ln, |lu|, |lv| lies. -1 when no face does, or only in front of its near plane or past its far plane.
inline int face_of(double lu, double lv, double ln, double near, double far) {
  const double au = std::abs(lu), av = std::abs(lv);
  if (ln < 0) return -1;
  int face;
  double d;
  if (ln >= au && ln >= av) {
    face = kTop;
    d = ln;
  } else if (au >= av) {
    face = lu > 0 ? kPlusU : kMinusU;
    d = au;
  } else {
    face = lv > 0 ? kPlusV : kMinusV;
    d = av;
  }
  return d >= near && d <= far ? face : -1;
}

// Renders the rows of F for one thread: buffers allocated once, reused for every patch and face. Each patch above
// the row's plane is drawn into each face that may see it (hemicube_raster.hpp), and the face gathered by its weights.
class RowRenderer {
 public:
  // corners: the 9 coordinates of each patch's 3 vertices, packed.
  RowRenderer(const Mesh& mesh, const std::vector<double>& corners, const HemicubeParams& p,
              const WeightTable& weights)
      : mesh_(mesh),
        corners_(corners),
        R_(p.resolution),
        rrv_(p.weights == HemicubeWeights::rrv2007),
        weights_(weights),
        local_(corners.size()),
        raster_(R_) {
    for (auto& list : within_) list.reserve(mesh.size());
    straddling_.reserve(mesh.size());
  }

  // row[j] += F_ij for every j; row[i] gets nothing.
  void render(size_t i, double* row) {
    const Patch& pi = mesh_.patches[i];
    const double area = pi.area();
    if (!(area > 0)) return;  // a degenerate patch has no normal and sends nothing
    const Vec3 n = pi.normal(), c = pi.centroid();
    // RRV's frame: side = normal × (1,2,3), or × (1,1,1) when the normal is parallel to (1,2,3).
    Vec3 side = n.cross({1, 2, 3});
    if (side.norm() < 1e-9) side = n.cross({1, 1, 1});
    const Vec3 u = side.normalized(), v = u.cross(n);
    near_ = rrv_ ? kRrvNear : kExactNearPerSize * std::sqrt(area);
    far_ = rrv_ ? kRrvFar : std::numeric_limits<double>::infinity();

    // Each triangle is transformed once. One whose corners all lie in one face's frustum lies wholly in it (the
    // frustum is convex) and is drawn there without clipping: most triangles, since patches are small. The others
    // go through every face's reject-and-clip path.
    for (auto& list : within_) list.clear();
    straddling_.clear();
    const size_t count = mesh_.size();
    for (size_t j = 0; j < count; ++j) {
      if (j == i) continue;
      const double* q = &corners_[9 * j];
      double* l = &local_[9 * j];
      for (int k = 0; k < 3; ++k) {
        const double dx = q[3 * k] - c.x, dy = q[3 * k + 1] - c.y, dz = q[3 * k + 2] - c.z;
        l[3 * k] = dx * u.x + dy * u.y + dz * u.z;
        l[3 * k + 1] = dx * v.x + dy * v.y + dz * v.z;
        l[3 * k + 2] = dx * n.x + dy * n.y + dz * n.z;
      }
      if (l[2] <= 0 && l[5] <= 0 && l[8] <= 0) continue;  // on or behind patch i's plane
      const int f = face_of(l[0], l[1], l[2], near_, far_);
      if (f >= 0 && f == face_of(l[3], l[4], l[5], near_, far_) && f == face_of(l[6], l[7], l[8], near_, far_))
        within_[f].push_back(static_cast<int32_t>(j));
      else
        straddling_.push_back(static_cast<int32_t>(j));
    }

    render_face<kTop>(row);
    render_face<kPlusU>(row);
    render_face<kMinusU>(row);
    render_face<kPlusV>(row);
    render_face<kMinusV>(row);
  }

 private:
  template <int F>
  void render_face(double* row) {
    raster_.begin(F, near_, far_);
    auto view = [this](int32_t j) {
      const double* l = &local_[9 * size_t(j)];
      return std::array<ViewVertex, 3>{to_view<F>(l[0], l[1], l[2]), to_view<F>(l[3], l[4], l[5]),
                                       to_view<F>(l[6], l[7], l[8])};
    };
    for (int32_t j : within_[F]) {
      const std::array<ViewVertex, 3> t = view(j);
      raster_.project(t.data(), 3, j);
    }
    for (int32_t j : straddling_) {
      const std::array<ViewVertex, 3> t = view(j);
      raster_.draw(t.data(), j);
    }
    // Gather: each run of pixels showing one patch adds its summed weight to that patch.
    const double* prefix = weights_.prefix[F].data();
    for (int r = 0; r < raster_.height(); ++r) {
      const int32_t* it = raster_.items(r);
      const double* pre = &prefix[size_t(r) * (R_ + 1)];
      for (int a = 0; a < R_;) {
        const int32_t shown = it[a];
        int b = a + 1;
        while (b < R_ && it[b] == shown) ++b;
        if (shown >= 0) row[shown] += pre[b] - pre[a];
        a = b;
      }
    }
    raster_.clear();
  }

  const Mesh& mesh_;
  const std::vector<double>& corners_;
  const int R_;
  const bool rrv_;
  const WeightTable& weights_;
  std::vector<double> local_;  // 9 per patch: (lu, lv, ln) of its three vertices, for the current row
  std::array<std::vector<int32_t>, kFaceCount> within_;  // patches wholly inside one face's frustum
  std::vector<int32_t> straddling_;                     // the other patches above the current patch's plane
  FaceRaster raster_;
  double near_ = kRrvNear, far_ = kRrvFar;
};

}  // namespace

HemicubeProgress stderr_progress() {
  return [](size_t done, size_t total, double seconds) {
    std::fprintf(stderr, "form factors: %zu/%zu patches, %.1f s, %.1f patches/s\n", done, total, seconds,
                 seconds > 0 ? done / seconds : 0.0);
  };
}

FormFactors compute_form_factor_rows(const Mesh& mesh, const HemicubeParams& params, size_t row_begin,
                                        size_t row_end, const HemicubeProgress& progress, double progress_interval_s) {
  validate(params);
  const size_t n = mesh.size();
  if (n > size_t(std::numeric_limits<int32_t>::max())) throw hpcgi::UsageError("too many patches for the hemicube");
  if (row_begin > row_end || row_end > n)
    throw hpcgi::UsageError("form-factor rows " + std::to_string(row_begin) + ".." + std::to_string(row_end) +
                            " are not rows of a mesh of " + std::to_string(n) + " patches");
  FormFactors ff;
  ff.n = n;
  ff.row_begin = row_begin;
  ff.row_end = row_end;
  ff.params = params;
  const size_t rows = row_end - row_begin;
  ff.values.assign(rows * n, 0.0f);
  const WeightTable weights = make_weights(params);
  std::vector<double> corners(9 * n);
  for (size_t j = 0; j < n; ++j)
    for (int k = 0; k < 3; ++k) {
      corners[9 * j + 3 * k] = mesh.patches[j].v[k].x;
      corners[9 * j + 3 * k + 1] = mesh.patches[j].v[k].y;
      corners[9 * j + 3 * k + 2] = mesh.patches[j].v[k].z;
    }

  using clock = std::chrono::steady_clock;
  const auto start = clock::now();
  const int64_t interval_ns = static_cast<int64_t>(progress_interval_s * 1e9);
  std::atomic<size_t> done{0};
  std::atomic<int64_t> next_report_ns{interval_ns};
  auto elapsed_ns = [&start] {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(clock::now() - start).count();
  };

#pragma omp parallel
  {
    RowRenderer renderer(mesh, corners, params, weights);
    std::vector<double> row(n, 0.0);
#pragma omp for schedule(dynamic, 1)
    for (int64_t k = 0; k < int64_t(rows); ++k) {
      const size_t i = row_begin + size_t(k);
      renderer.render(i, row.data());
      float* out = &ff.values[size_t(k) * n];
      for (size_t j = 0; j < n; ++j) {
        const float f = static_cast<float>(row[j]);
        out[j] = f > params.threshold ? f : 0.0f;  // compared as stored: no kept value is <= threshold
        row[j] = 0.0;
      }
      out[i] = 0.0f;
      const size_t d = ++done;
      if (progress) {
        const int64_t now = elapsed_ns();
        int64_t due = next_report_ns.load();
        if (now >= due && next_report_ns.compare_exchange_strong(due, now + interval_ns)) {
#pragma omp critical(hemicube_progress)
          progress(d, rows, now * 1e-9);
        }
      }
    }
  }
  // A run long enough to have reported ends with a report of the whole.
  if (progress && elapsed_ns() >= interval_ns) progress(rows, rows, elapsed_ns() * 1e-9);
  return ff;
}

FormFactors compute_form_factors(const Mesh& mesh, const HemicubeParams& params, const HemicubeProgress& progress,
                                 double progress_interval_s) {
  return compute_form_factor_rows(mesh, params, 0, mesh.size(), progress, progress_interval_s);
}

double hemicube_memory_bytes(size_t n, size_t rows, int resolution, int threads) {
  const double dn = double(n), r2 = double(resolution) * double(resolution) + kLanes;
  // The weight table, shared: prefix sums of doubles over the five faces' 3R² pixels (R + 1 per row). Measured on a
  // 12-patch box at R = 4096: 685 MB peak with one thread, 816 MB with two (this estimate: 553 MB and 688 MB, besides
  // the program's own ~130 MB).
  const double weights = 8.0 * (double(resolution) + 1) * 2.0 * double(resolution) * 1.5;
  return 4.0 * double(rows) * dn + 72.0 * dn + weights + double(threads) * ((8.0 + 72.0 + 6 * 4.0) * dn + 8.0 * r2);
}

std::vector<uint64_t> hemicube_row_work(const Mesh& mesh, const HemicubeParams& params, size_t sample) {
  validate(params);
  const size_t n = mesh.size();
  const size_t stride = std::max<size_t>(1, (n + sample - 1) / std::max<size_t>(1, sample));
  const double pixels = 3.0 * double(params.resolution) * double(params.resolution);
  const double per_front = kWorkPerFrontPatchNs + kWorkPerFrontPatchPerRNs * params.resolution;
  std::vector<uint64_t> work(n);
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < int64_t(n); ++i) {
    const Patch& pi = mesh.patches[size_t(i)];
    if (!(pi.area() > 0)) {  // the renderer returns at once
      work[size_t(i)] = 1;
      continue;
    }
    const Vec3 nrm = pi.normal(), c = pi.centroid();
    size_t front = 0;
    for (size_t j = 0; j < n; j += stride) {
      if (j == size_t(i)) continue;
      const Patch& pj = mesh.patches[j];
      bool in_front = false;
      for (int k = 0; k < 3; ++k) in_front = in_front || (pj.v[k] - c).dot(nrm) > 0;
      front += in_front;
    }
    work[size_t(i)] = uint64_t(kWorkPerPatchNs * double(n) + per_front * double(front * stride) +
                               kWorkPerPixelNs * pixels);
  }
  return work;
}

}  // namespace radiosity
