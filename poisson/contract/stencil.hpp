// The five-point stencil of -Laplace(u) (times h²), written once for every backend, CPU and CUDA:
//   (A x)_k = d x_k - x_west - x_east - x_south - x_north,
// d = 4 on the model problem (a multigrid level adds its edge term on the last row and column, mg.hpp).
// The terms are subtracted in this order, left to right, in every backend, so that they round alike. West and east
// are the neighbours in the row (column k - 1, k + 1), south and north the rows j - 1 and j + 1.
#pragma once

#if defined(__CUDACC__)
#define POISSON_STENCIL __host__ __device__ __forceinline__
#else
#define POISSON_STENCIL inline
#endif

namespace poisson {

// (A x) at one point from its value c, its diagonal d and its four neighbours.
template <class T>
POISSON_STENCIL T five_point(T d, T c, T west, T east, T south, T north) {
  return d * c - west - east - south - north;
}

// The model problem's (A x) at padded column k of row x, with the rows below (south) and above (north).
template <class T>
POISSON_STENCIL T five_point_rows(const T* x, const T* south, const T* north, long k) {
  return five_point(T(4), x[k], x[k - 1], x[k + 1], south[k], north[k]);
}

// The model problem's (A x) at index k of a padded array with row stride s.
template <class T>
POISSON_STENCIL T five_point_at(const T* x, long s, long k) {
  return five_point(T(4), x[k], x[k - 1], x[k + 1], x[k - s], x[k + s]);
}

// b_k + the four neighbours: Gauss-Seidel's new x_k is this over the diagonal.
template <class T>
POISSON_STENCIL T plus_neighbours(T b, T west, T east, T south, T north) {
  return b + west + east + south + north;
}

}  // namespace poisson
