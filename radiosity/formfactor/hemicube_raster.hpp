// The hemicube's software rasteriser: one face's item and depth buffers, the clipping of a triangle in view
// coordinates to the face's frustum, its projection to fixed-point pixels and the scan of its pixel rows.
// Internal to radiosity/formfactor/ (hemicube.cpp's renderer draws every patch through it); inline, so that the
// compiler sees the whole per-triangle path at once.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "radiosity/formfactor/hemicube_weights.hpp"

namespace radiosity::hemicube {

// Vertices snap to 1/256 pixel, like OpenGL hardware with 8 sub-pixel bits; edge functions are then exact integers,
// so the top-left rule gives every pixel centre on a shared edge to exactly one of the two triangles.
constexpr int64_t kSub = 256;
// Triangles are clipped to a guard band twice the face's field of view (|x|, |y| <= 2d) as well as to the near
// plane, which bounds the fixed-point coordinates; clipping outside the face changes no pixel inside it.
constexpr double kGuard = 2.0;
// Pixels a row's span is filled in at a time (8 floats: one AVX2 vector).
constexpr int kLanes = 8;

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

inline int64_t floor_div(int64_t a, int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }
inline int64_t ceil_div(int64_t a, int64_t b) { return -floor_div(-a, b); }

struct Fixed {
  int64_t x, y;  // pixel coordinates × kSub
  double z;      // 1/d
};

// A triangle's three edge functions at the first pixel centre of its bounding box and their steps per pixel, and
// its depth 1/d there and per pixel. Edge k runs from v[k+1] to v[k+2] and is the barycentric weight of v[k]:
// E_k(p) = A_k p.x + B_k p.y + C_k > 0 inside. A pixel centre on an edge belongs to the triangle only if the edge
// is a top or left one.
struct Edges {
  int64_t e_row[3], step_x[3], step_y[3];
  double z_row = 0, dz_dx = 0, dz_dy = 0;

  Edges(const Fixed v[3], int64_t x0, int64_t y0, int64_t area2) {
    const int64_t half = kSub / 2;
    const int64_t px = x0 * kSub + half, py = y0 * kSub + half;
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
  }
};

// A triangle covers one interval of each pixel row; its ends follow exactly from the integer edge functions:
// E_k + s_k·d >= 0 for the pixel d = x - x0 of the row, s_k the step per pixel, holds from d = ceil(-E_k/s_k)
// on when s_k > 0 and up to d = floor(E_k/|s_k|) when s_k < 0 (an edge with s_k = 0 keeps the whole row or
// none). So only covered pixels are visited. Rows are short (about 5 pixels on average for room3.xml at
// R = 256), so the ends are kept without a division per row: q_k = floor(E_k/u_k) with u_k = |s_k| (1 when
// s_k = 0: then q_k = E_k) and its remainder r_k in [0, u_k), stepped by the quotient and remainder of the
// per-row step t_k as Bresenham's line does: exact, the same intervals as dividing.
class RowSpans {
 public:
  explicit RowSpans(const Edges& e) : step_x_(e.step_x) {
    for (int k = 0; k < 3; ++k) {
      u_[k] = step_x_[k] > 0 ? step_x_[k] : step_x_[k] < 0 ? -step_x_[k] : 1;
      q_[k] = floor_div(e.e_row[k], u_[k]);
      r_[k] = e.e_row[k] - q_[k] * u_[k];
      dq_[k] = floor_div(e.step_y[k], u_[k]);
      dr_[k] = e.step_y[k] - dq_[k] * u_[k];
    }
  }

  // The covered pixels [lo, hi] of the current row within [x0, x1] (hi < lo: none); then steps to the next row.
  void next(int64_t x0, int64_t x1, int64_t& lo, int64_t& hi) {
    lo = x0;
    hi = x1;
    for (int k = 0; k < 3; ++k) {
      if (step_x_[k] > 0) lo = std::max(lo, x0 - q_[k]);
      else if (step_x_[k] < 0) hi = std::min(hi, x0 + q_[k]);
      else if (q_[k] < 0) hi = lo - 1;
      q_[k] += dq_[k];
      r_[k] += dr_[k];
      const int64_t carry = r_[k] >= u_[k];
      q_[k] += carry;
      r_[k] -= carry * u_[k];
    }
  }

 private:
  const int64_t* step_x_;
  int64_t u_[3], q_[3], r_[3], dq_[3], dr_[3];
};

// Depth-tests pixels [first, last] of one row (offsets from the row's x0, at `it` and `dp`) against depth z_row +
// dz_dx·x, writing item where the triangle is nearer. The interval in blocks of kLanes pixels, every lane computed
// and stored, the lanes past the interval's end storing back what they read (the buffers have kLanes pixels of slack
// at the end): a row is about 5 pixels, so a loop with a vector body and a scalar tail would run mostly in its tail.
// Branch-free (select, then store; `&`, not `&&`, which is a branch) and with 32-bit offsets (AVX2 converts int32 to
// double in vectors, not int64), so that the lanes become vector instructions. The depth is evaluated afresh at each
// pixel rather than stepped, which would chain every pixel on the latency of a floating-point add.
inline void fill_span(int32_t* it, float* dp, int first, int last, double z_row, double dz_dx, int32_t item) {
  for (int x = first; x <= last; x += kLanes)
#pragma omp simd
    for (int l = 0; l < kLanes; ++l) {
      const float z = static_cast<float>(z_row + dz_dx * double(x + l)), old = dp[x + l];
      const bool nearer = (x + l <= last) & (z > old);  // larger 1/d is nearer
      dp[x + l] = nearer ? z : old;
      it[x + l] = nearer ? item : it[x + l];
    }
}

// One face's buffers, R pixels wide and `height` rows high, and the drawing of triangles into them.
class FaceRaster {
 public:
  explicit FaceRaster(int R) : R_(R), item_(size_t(R) * R + kLanes, -1), depth_(size_t(R) * R + kLanes, 0.0f) {}

  // Starts face `face` with the near and far planes of the current row.
  void begin(int face, double near, double far) {
    face_ = face;
    height_ = face == kTop ? R_ : R_ / 2;
    near_ = near;
    far_ = far;
  }
  int height() const { return height_; }
  const int32_t* items(int r) const { return &item_[size_t(r) * R_]; }
  // Leaves the buffers clean for the next face.
  void clear() {
    std::fill_n(item_.begin(), size_t(R_) * height_, -1);
    std::fill_n(depth_.begin(), size_t(R_) * height_, 0.0f);
  }

  // Rejects triangles wholly outside the face's frustum, clips the rest to the near (and far) plane and the guard
  // band, and rasterises the resulting convex polygon as a fan.
  void draw(const ViewVertex* t, int32_t item) {
    if (outside(t)) return;
    auto inside_all = [this](const ViewVertex& p) {
      return p.d >= near_ && p.d <= far_ && std::abs(p.x) <= kGuard * p.d && std::abs(p.y) <= kGuard * p.d;
    };
    if (inside_all(t[0]) && inside_all(t[1]) && inside_all(t[2])) return project(t, 3, item);
    ViewVertex poly[2][12];
    std::copy(t, t + 3, poly[0]);
    const int cur = clip(poly);
    if (cur >= 0) project(poly[cur], count_, item);
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

 private:
  // Whether all three corners lie beyond one plane of the face's frustum.
  bool outside(const ViewVertex* t) const {
    const double ymin = face_ == kTop ? -1.0 : 0.0;
    auto all = [&t](auto out) { return out(t[0]) && out(t[1]) && out(t[2]); };
    return all([](const ViewVertex& p) { return p.x > p.d; }) || all([](const ViewVertex& p) { return p.x < -p.d; }) ||
           all([](const ViewVertex& p) { return p.y > p.d; }) ||
           all([ymin](const ViewVertex& p) { return p.y < ymin * p.d; }) ||
           all([this](const ViewVertex& p) { return p.d < near_; }) ||
           all([this](const ViewVertex& p) { return p.d > far_; });
  }

  // Sutherland-Hodgman of the triangle in poly[0] against the planes a·x + b·y + c·d + e >= 0; near first, so that
  // the guard planes only ever meet points in front of the eye. Returns which of poly holds the clipped polygon (its
  // corners: count_), or -1 when less than a triangle is left.
  int clip(ViewVertex (&poly)[2][12]) {
    const double planes[6][4] = {{0, 0, 1, -near_},   {0, 0, -1, far_},  {-1, 0, kGuard, 0},
                                 {1, 0, kGuard, 0},   {0, -1, kGuard, 0}, {0, 1, kGuard, 0}};
    int count = 3, cur = 0;
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
      if (count < 3) return -1;
    }
    count_ = count;
    return cur;
  }

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
    Edges e(v, x0, y0, area2);
    RowSpans spans(e);
    for (int64_t y = y0; y <= y1; ++y) {
      int64_t lo, hi;
      spans.next(x0, x1, lo, hi);
      fill_span(&item_[size_t(y) * R_ + x0], &depth_[size_t(y) * R_ + x0], int(lo - x0), int(hi - x0), e.z_row,
                e.dz_dx, item);
      e.z_row += e.dz_dy;
    }
  }

  const int R_;
  std::vector<int32_t> item_;  // which patch each pixel of the current face shows, -1 none
  std::vector<float> depth_;   // 1/d of that patch there, 0 none
  double near_ = 0, far_ = 0;
  int face_ = kTop, height_ = 0, count_ = 0;
};

}  // namespace radiosity::hemicube
