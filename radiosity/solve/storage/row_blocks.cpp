#include "radiosity/solve/storage/row_blocks.hpp"

#include <omp.h>

#include <algorithm>

#include "radiosity/solve/storage/ff_matrix.hpp"

namespace radiosity {
namespace {

// A stored value other than ±0 (NaN included: the product then makes the row NaN, as the solvers' would).
bool nonzero(float f) { return !(f == 0.0f); }
bool nonzero(uint16_t bits) { return (bits & 0x7fffu) != 0; }  // float16 and bfloat16 alike

// fn(j, v) for each stored value v of row i that is not 0 (dense: every column; sparse: its entries).
template <class S, class Fn>
void row_values(const FFMatrixView& F, const S* data, size_t i, Fn&& fn) {
  if (F.storage == FFStorage::dense) {
    const S* r = data + i * F.n;
    for (size_t j = 0; j < F.n; ++j)
      if (nonzero(r[j])) fn(j, r[j]);
    return;
  }
  for_each_entry(F, i, [&](size_t k, size_t j) {
    if (nonzero(data[k])) fn(j, data[k]);
  });
}

template <class S>
void build(const FFMatrixView& F, const std::vector<int32_t>& rows, int threads, std::vector<int64_t>& seg_start,
           std::vector<int64_t>& col_start, std::vector<BlockSegment>& seg, std::vector<S>& values,
           size_t& nonzeros) {
  const size_t n = F.n, nb = (n + kBlockRows - 1) / kBlockRows;
  const S* data = static_cast<const S*>(F.data);
  std::vector<char> held(n, rows.empty() ? 1 : 0);  // dense F: the rows to hold
  for (int32_t i : rows) held[size_t(i)] = 1;
  // Pass 1: each block's columns and segments, counted. Pass 2: the values, at their places.
  std::vector<int64_t> ncols(nb + 1, 0), nsegs(nb + 1, 0);
  std::vector<std::vector<BlockSegment>> block_seg(nb);
  auto mark = [&](size_t b, std::vector<uint32_t>& stamp) {  // stamp[j] = b + 1 where the block has a value
    for (size_t i = b * kBlockRows; i < std::min(n, (b + 1) * kBlockRows); ++i)
      if (held[i]) row_values(F, data, i, [&](size_t j, S) { stamp[j] = uint32_t(b + 1); });
  };
#pragma omp parallel num_threads(threads)
  {
    std::vector<uint32_t> stamp(n, 0);
#pragma omp for schedule(dynamic, 4)
    for (size_t b = 0; b < nb; ++b) {
      mark(b, stamp);
      std::vector<BlockSegment>& s = block_seg[b];
      for (size_t j = 0; j < n; ++j) {
        if (stamp[j] != b + 1) continue;
        if (!s.empty() && s.back().col + s.back().length == j)
          ++s.back().length;
        else
          s.push_back({uint32_t(j), 1});
      }
      int64_t c = 0;
      for (const BlockSegment& g : s) c += g.length;
      ncols[b + 1] = c, nsegs[b + 1] = int64_t(s.size());
    }
  }
  for (size_t b = 0; b < nb; ++b) ncols[b + 1] += ncols[b], nsegs[b + 1] += nsegs[b];
  col_start = ncols, seg_start = nsegs;
  seg.resize(size_t(nsegs[nb]));
  values.assign(size_t(ncols[nb]) * kBlockRows, S(0));
  size_t nz = 0;
#pragma omp parallel num_threads(threads) reduction(+ : nz)
  {
    std::vector<uint32_t> place(n);  // a column's place in its block
#pragma omp for schedule(dynamic, 4)
    for (size_t b = 0; b < nb; ++b) {
      uint32_t p = 0;
      for (const BlockSegment& g : block_seg[b])
        for (uint32_t j = g.col; j < g.col + g.length; ++j) place[j] = p++;
      std::copy(block_seg[b].begin(), block_seg[b].end(), seg.begin() + nsegs[b]);
      S* v = values.data() + size_t(ncols[b]) * kBlockRows;
      for (size_t i = b * kBlockRows; i < std::min(n, (b + 1) * kBlockRows); ++i)
        if (held[i])
          row_values(F, data, i, [&](size_t j, S f) {
            v[size_t(place[j]) * kBlockRows + (i - b * kBlockRows)] = f;
            ++nz;
          });
      std::vector<BlockSegment>().swap(block_seg[b]);
    }
  }
  nonzeros = nz;
}

}  // namespace

RowBlockMatrix::RowBlockMatrix(const FFMatrixView& F, const std::vector<int32_t>& rows, int threads)
    : n_(F.n), values_(F.values), scale_(F.scale) {
  if (values_ == FFValues::float32)
    build(F, rows, threads, seg_start_, col_start_, seg_, f32_, nonzeros_);
  else
    build(F, rows, threads, seg_start_, col_start_, seg_, u16_, nonzeros_);
}

double RowBlockMatrix::bytes() const {
  return double(columns()) * double(kBlockRows * value_bytes(values_)) + double(seg_.size() * sizeof(BlockSegment)) +
         double((seg_start_.size() + col_start_.size()) * sizeof(int64_t));
}

}  // namespace radiosity
