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

namespace radiosity {
namespace {

// RRV's gluPerspective(90, 1, 1e-3, 50).
constexpr double kRrvNear = 1e-3;
constexpr double kRrvFar = 50;
// With exact weights nothing should be lost to the near plane: a plane this close to the centroid (relative to the
// patch's size) cuts away only geometry that pierces the patch itself. The far plane is dropped.
constexpr double kExactNearPerSize = 1e-6;
// Vertices snap to 1/256 pixel, like OpenGL hardware with 8 sub-pixel bits; edge functions are then exact integers,
// so the top-left rule gives every pixel centre on a shared edge to exactly one of the two triangles.
constexpr int64_t kSub = 256;
// Triangles are clipped to a guard band twice the face's field of view (|x|, |y| <= 2d) as well as to the near
// plane, which bounds the fixed-point coordinates; clipping outside the face changes no pixel inside it.
constexpr double kGuard = 2.0;
// hemicube_row_work's cost model, in nanoseconds on one core: transforming a patch into the row's frame; clipping
// and rasterising a patch in front of the row's patch (more pixels to fill at a finer hemicube: a + b·R); clearing
// and gathering one pixel. Fitted to single rows timed on this project's 2-core development machine (scene1, scene2
// at R = 32, 128, 256, room3 at R = 64: per row, const + per-front-patch cost explains the time within 12-18% rms);
// only their ratios matter for a split.
constexpr double kWorkPerPatchNs = 25;
constexpr double kWorkPerFrontPatchNs = 50, kWorkPerFrontPatchPerRNs = 0.5;
constexpr double kWorkPerPixelNs = 1.5;
// Pixels a row's span is filled in at a time (8 floats: one AVX2 vector).
constexpr int kLanes = 8;

// The five views. In the patch's frame (u, v, n) a point has local coordinates (lu, lv, ln); a view sees it at view
// coordinates (x, y, d): image point (x/d, y/d), depth d along the view direction. On the side views y is the height
// ln, so the hemicube's half of a side face is 0 <= y/d <= 1.
enum Face { kTop, kPlusU, kMinusU, kPlusV, kMinusV, kFaceCount };

struct ViewVertex {
  double x, y, d;
};

template <int F>
inline ViewVertex to_view(double lu, double lv, double ln) {
  if constexpr (F == kTop) return {lu, lv, ln};
  if constexpr (F == kPlusU) return {lv, ln, lu};
  if constexpr (F == kMinusU) return {lv, ln, -lu};
  if constexpr (F == kPlusV) return {lu, ln, lv};
  return {lu, ln, -lv};
}

// Pixel weights per face, row-major, width R, height R (top) or R/2 (sides); row 0 is y/d = -1 on the top face and
// the horizon on a side face. The rrv2007 table follows RRV's unfolded cross (FormFactorEngine::renderFullScene and
// getFF): its pixel (X, Y) of the 2R × 2R cross has weight cos(π(X-R)/2R)·cos(π(Y-R)/2R), X and Y counted from the
// cross's corner (so the cosines are taken at pixel corners, as RRV does). Mapped to our faces: the along-axis
// pixel a sits at a - R/2 on every face; the height row r sits at R-1-r on the +u, +v faces and r-R on the -u, -v
// faces (RRV renders those views upside down or mirrored), and at r - R/2 on the top.
// Stored as prefix sums along each pixel row (R + 1 entries per row, the first 0), so that a run of pixels showing
// the same patch costs one subtraction when the face is gathered.
struct WeightTable {
  std::array<std::vector<double>, kFaceCount> prefix;
};

WeightTable make_weights(const HemicubeParams& p) {
  const int R = p.resolution;
  WeightTable t;
  for (int f = 0; f < kFaceCount; ++f) {
    const int height = f == kTop ? R : R / 2;
    t.prefix[f].assign(size_t(R + 1) * height, 0.0);
    for (int r = 0; r < height; ++r)
      for (int a = 0; a < R; ++a) {
        double w;
        if (p.weights == HemicubeWeights::exact) {
          const double dA = 4.0 / (double(R) * R), x = (a + 0.5) * 2.0 / R - 1.0;
          if (f == kTop) {
            const double y = (r + 0.5) * 2.0 / R - 1.0, q = x * x + y * y + 1.0;
            w = dA / (M_PI * q * q);
          } else {
            const double z = (r + 0.5) * 2.0 / R, q = x * x + z * z + 1.0;
            w = z * dA / (M_PI * q * q);
          }
        } else {
          auto c = [R](int k) { return std::cos(M_PI * k / (2.0 * R)); };
          const int h = f == kTop ? r - R / 2 : (f == kPlusU || f == kPlusV) ? R - 1 - r : r - R;
          w = c(a - R / 2) * c(h) * 2.0 / (3.0 * double(R) * R);
        }
        double* pre = &t.prefix[f][size_t(r) * (R + 1)];
        pre[a + 1] = pre[a] + w;
      }
  }
  return t;
}

inline int64_t floor_div(int64_t a, int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }
inline int64_t ceil_div(int64_t a, int64_t b) { return -floor_div(-a, b); }

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

// Renders the rows of F for one thread: buffers allocated once, reused for every patch and face.
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
        item_(size_t(R_) * R_ + kLanes, -1),
        depth_(size_t(R_) * R_ + kLanes, 0.0f) {
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
    face_ = F;
    height_ = F == kTop ? R_ : R_ / 2;
    auto view = [this](int32_t j) {
      const double* l = &local_[9 * size_t(j)];
      return std::array<ViewVertex, 3>{to_view<F>(l[0], l[1], l[2]), to_view<F>(l[3], l[4], l[5]),
                                       to_view<F>(l[6], l[7], l[8])};
    };
    for (int32_t j : within_[F]) {
      const std::array<ViewVertex, 3> t = view(j);
      project(t.data(), 3, j);
    }
    for (int32_t j : straddling_) {
      const std::array<ViewVertex, 3> t = view(j);
      draw(t.data(), j);
    }
    // Gather: each run of pixels showing one patch adds its summed weight to that patch; the buffers are left
    // clean for the next face.
    const double* prefix = weights_.prefix[F].data();
    for (int r = 0; r < height_; ++r) {
      const int32_t* it = &item_[size_t(r) * R_];
      const double* pre = &prefix[size_t(r) * (R_ + 1)];
      for (int a = 0; a < R_;) {
        const int32_t shown = it[a];
        int b = a + 1;
        while (b < R_ && it[b] == shown) ++b;
        if (shown >= 0) row[shown] += pre[b] - pre[a];
        a = b;
      }
    }
    std::fill_n(item_.begin(), size_t(R_) * height_, -1);
    std::fill_n(depth_.begin(), size_t(R_) * height_, 0.0f);
  }

  // Rejects triangles wholly outside the face's frustum, clips the rest to the near (and far) plane and the guard
  // band, and rasterises the resulting convex polygon as a fan.
  void draw(const ViewVertex* t, int32_t item) {
    const double ymin = face_ == kTop ? -1.0 : 0.0;
    auto all = [&t](auto outside) { return outside(t[0]) && outside(t[1]) && outside(t[2]); };
    if (all([](const ViewVertex& p) { return p.x > p.d; }) || all([](const ViewVertex& p) { return p.x < -p.d; }) ||
        all([](const ViewVertex& p) { return p.y > p.d; }) ||
        all([ymin](const ViewVertex& p) { return p.y < ymin * p.d; }) ||
        all([this](const ViewVertex& p) { return p.d < near_; }) ||
        all([this](const ViewVertex& p) { return p.d > far_; }))
      return;

    auto inside_all = [this](const ViewVertex& p) {
      return p.d >= near_ && p.d <= far_ && std::abs(p.x) <= kGuard * p.d && std::abs(p.y) <= kGuard * p.d;
    };
    ViewVertex poly[2][12];
    int count = 3;
    std::copy(t, t + 3, poly[0]);
    int cur = 0;
    if (!(inside_all(t[0]) && inside_all(t[1]) && inside_all(t[2]))) {
      // Sutherland-Hodgman against the planes a·x + b·y + c·d + e >= 0; near first, so that the guard planes
      // only ever meet points in front of the eye.
      const double planes[6][4] = {{0, 0, 1, -near_},   {0, 0, -1, far_},  {-1, 0, kGuard, 0},
                                   {1, 0, kGuard, 0},   {0, -1, kGuard, 0}, {0, 1, kGuard, 0}};
      for (const auto& pl : planes) {
        if (std::isinf(pl[3])) continue;  // no far plane
        auto dist = [&pl](const ViewVertex& p) { return pl[0] * p.x + pl[1] * p.y + pl[2] * p.d + pl[3]; };
        const ViewVertex* in = poly[cur];
        ViewVertex* out = poly[1 - cur];
        int m = 0;
        for (int k = 0; k < count; ++k) {
          const ViewVertex& a = in[k];
          const ViewVertex& b = in[(k + 1) % count];
          const double da = dist(a), db = dist(b);
          if (da >= 0) out[m++] = a;
          if ((da >= 0) != (db >= 0)) {
            const double s = da / (da - db);
            out[m++] = {a.x + s * (b.x - a.x), a.y + s * (b.y - a.y), a.d + s * (b.d - a.d)};
          }
        }
        count = m;
        cur = 1 - cur;
        if (count < 3) return;
      }
    }
    project(poly[cur], count, item);
  }

  // Projects a convex polygon in front of the eye to fixed-point pixel coordinates, keeping 1/d as the depth (it
  // is affine in screen space), and rasterises it as a fan.
  void project(const ViewVertex* poly, int count, int32_t item) {
    const double half = 0.5 * R_, yoff = face_ == kTop ? 1.0 : 0.0;
    Fixed s[12];
    for (int k = 0; k < count; ++k) {
      const ViewVertex& p = poly[k];
      const double inv = 1.0 / p.d;
      s[k] = {static_cast<int64_t>(std::floor((p.x * inv + 1.0) * half * kSub + 0.5)),
              static_cast<int64_t>(std::floor((p.y * inv + yoff) * half * kSub + 0.5)), inv};
    }
    for (int k = 1; k + 1 < count; ++k) raster(s[0], s[k], s[k + 1], item);
  }

  struct Fixed {
    int64_t x, y;  // pixel coordinates × kSub
    double z;      // 1/d
  };

  // Rasterises a triangle within its bounding box, sampling pixel centres with incremental integer edge functions.
  // Ties follow the top-left rule: a centre exactly on an edge shared by two triangles goes to exactly one of them,
  // so meshes have neither cracks nor double-counted pixels.
  void raster(Fixed a, Fixed b, Fixed c, int32_t item) {
    int64_t area2 = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if (area2 == 0) return;
    if (area2 < 0) {  // no culling: both windings are drawn, turned counter-clockwise here
      std::swap(b, c);
      area2 = -area2;
    }
    const Fixed v[3] = {a, b, c};
    const int64_t half = kSub / 2;
    const int64_t x0 = std::max<int64_t>(0, ceil_div(std::min({a.x, b.x, c.x}) - half, kSub));
    const int64_t x1 = std::min<int64_t>(R_ - 1, floor_div(std::max({a.x, b.x, c.x}) - half, kSub));
    const int64_t y0 = std::max<int64_t>(0, ceil_div(std::min({a.y, b.y, c.y}) - half, kSub));
    const int64_t y1 = std::min<int64_t>(height_ - 1, floor_div(std::max({a.y, b.y, c.y}) - half, kSub));
    if (x0 > x1 || y0 > y1) return;

    // Edge k runs from v[k+1] to v[k+2] and is the barycentric weight of v[k]: E_k(p) = A_k p.x + B_k p.y + C_k > 0
    // inside. A pixel centre on an edge belongs to the triangle only if the edge is a top or left one.
    const int64_t px = x0 * kSub + half, py = y0 * kSub + half;
    int64_t e_row[3], step_x[3], step_y[3];
    double z_row = 0, dz_dx = 0, dz_dy = 0;
    for (int k = 0; k < 3; ++k) {
      const Fixed& p = v[(k + 1) % 3];
      const Fixed& q = v[(k + 2) % 3];
      const int64_t A = -(q.y - p.y), B = q.x - p.x;
      const int64_t e = A * (px - p.x) + B * (py - p.y);
      const bool top_left = (q.y - p.y) < 0 || ((q.y == p.y) && (q.x - p.x) < 0);
      e_row[k] = e - (top_left ? 0 : 1);
      step_x[k] = A * kSub;
      step_y[k] = B * kSub;
      z_row += double(e) * v[k].z;
      dz_dx += double(A * kSub) * v[k].z;
      dz_dy += double(B * kSub) * v[k].z;
    }
    const double inv_area = 1.0 / double(area2);
    z_row *= inv_area;
    dz_dx *= inv_area;
    dz_dy *= inv_area;

    // A triangle covers one interval of each pixel row; its ends follow exactly from the integer edge functions:
    // E_k + s_k·d >= 0 for the pixel d = x - x0 of the row, s_k the step per pixel, holds from d = ceil(-E_k/s_k)
    // on when s_k > 0 and up to d = floor(E_k/|s_k|) when s_k < 0 (an edge with s_k = 0 keeps the whole row or
    // none). So only covered pixels are visited. Rows are short (about 5 pixels on average for room3.xml at
    // R = 256), so the ends are kept without a division per row: q_k = floor(E_k/u_k) with u_k = |s_k| (1 when
    // s_k = 0: then q_k = E_k) and its remainder r_k in [0, u_k), stepped by the quotient and remainder of the
    // per-row step t_k as Bresenham's line does: exact, the same intervals as dividing.
    int64_t u[3], q[3], r[3], dq[3], dr[3];
    for (int k = 0; k < 3; ++k) {
      u[k] = step_x[k] > 0 ? step_x[k] : step_x[k] < 0 ? -step_x[k] : 1;
      q[k] = floor_div(e_row[k], u[k]);
      r[k] = e_row[k] - q[k] * u[k];
      dq[k] = floor_div(step_y[k], u[k]);
      dr[k] = step_y[k] - dq[k] * u[k];
    }
    // The depth is evaluated afresh at each pixel rather than stepped, which would chain every pixel on the latency
    // of a floating-point add.
    for (int64_t y = y0; y <= y1; ++y) {
      int64_t lo = x0, hi = x1;
      for (int k = 0; k < 3; ++k) {
        if (step_x[k] > 0) lo = std::max(lo, x0 - q[k]);
        else if (step_x[k] < 0) hi = std::min(hi, x0 + q[k]);
        else if (q[k] < 0) hi = lo - 1;
        q[k] += dq[k];
        r[k] += dr[k];
        const int64_t carry = r[k] >= u[k];
        q[k] += carry;
        r[k] -= carry * u[k];
      }
      int32_t* it = &item_[size_t(y) * R_];
      float* dp = &depth_[size_t(y) * R_];
      // The interval in blocks of kLanes pixels, every lane computed and stored, the lanes past the interval's end
      // storing back what they read (the buffers have kLanes pixels of slack at the end): a row is about 5 pixels,
      // so a loop with a vector body and a scalar tail would run mostly in its tail. Branch-free (select, then
      // store; `&`, not `&&`, which is a branch) and with 32-bit offsets (AVX2 converts int32 to double in vectors,
      // not int64), so that the lanes become vector instructions.
      const int first = int(lo - x0), last = int(hi - x0);
      dp += x0;
      it += x0;
      for (int x = first; x <= last; x += kLanes)
#pragma omp simd
        for (int l = 0; l < kLanes; ++l) {
          const float z = static_cast<float>(z_row + dz_dx * double(x + l)), old = dp[x + l];
          const bool nearer = (x + l <= last) & (z > old);  // larger 1/d is nearer
          dp[x + l] = nearer ? z : old;
          it[x + l] = nearer ? item : it[x + l];
        }
      z_row += dz_dy;
    }
  }

  const Mesh& mesh_;
  const std::vector<double>& corners_;
  const int R_;
  const bool rrv_;
  const WeightTable& weights_;
  std::vector<double> local_;  // 9 per patch: (lu, lv, ln) of its three vertices, for the current row
  std::array<std::vector<int32_t>, kFaceCount> within_;  // patches wholly inside one face's frustum
  std::vector<int32_t> straddling_;                     // the other patches above the current patch's plane
  std::vector<int32_t> item_;          // which patch each pixel of the current face shows, -1 none
  std::vector<float> depth_;           // 1/d of that patch there, 0 none
  double near_ = kRrvNear, far_ = kRrvFar;
  int face_ = kTop, height_ = 0;
};

}  // namespace

HemicubeProgress stderr_progress() {
  return [](size_t done, size_t total, double seconds) {
    std::fprintf(stderr, "form factors: %zu/%zu patches, %.1f s, %.1f patches/s\n", done, total, seconds,
                 seconds > 0 ? done / seconds : 0.0);
  };
}

double hemicube_weight_total(const HemicubeParams& params) {
  validate(params);
  const WeightTable t = make_weights(params);
  const size_t stride = size_t(params.resolution) + 1;
  double sum = 0;
  for (const auto& face : t.prefix)
    for (size_t end = stride - 1; end < face.size(); end += stride) sum += face[end];
  return sum;
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
