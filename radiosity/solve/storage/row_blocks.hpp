// F laid out for the product with many right-hand sides (relighting's light basis, linalg.hpp's
// multi_affine_matvec): rows in blocks of kBlockRows, each block holding the columns where any of its rows keeps a
// value, kBlockRows values a column (0 where a row has none), in segments of consecutive columns. A column of a
// block is then one vector of 16 floats, multiplied by every right-hand side's x_j broadcast (row_block_kernels.hpp):
// 24 fused multiply-adds for 8 right-hand sides of three channels, against the two or more loads, a broadcast and a
// column a value that the per-value products pay (multi-right-hand-side kernels tried before: docs/design-notes.md, "Sparse F
// for the relighting").
//
// What it costs: the zeros in a block's columns. On room3.xml at R = 256 (9680 patches, 17.5 M non-zeros) blocks
// over all rows hold 1.67 M columns of 16, 66% of their values non-zero (8 rows: 75%, 4: 85%; a count over
// build/ff/bench-room3.ff), 107 MB in float32 against runs' 78 MB; without the rows of reflectivity 0, as relight
// builds them, 95.7 MB, 67% (make bench's records). It is built from F in any storage, once, for as long as the
// right-hand sides are many, beside the F the solvers read.
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

#include "radiosity/solve/storage/ff_matrix.hpp"

namespace radiosity {

inline constexpr size_t kBlockRows = 16;

// Columns col .. col + length - 1 of a block.
struct BlockSegment {
  uint32_t col, length;
};

class RowBlockMatrix {
 public:
  // From F in any storage. rows: the rows to hold (dense_rows_to_compute: patches of reflectivity 0 have none), or
  // empty for every row; sparse storages hold no values in those rows anyway. Values are copied as stored (float32,
  // or float16/bfloat16 bits with F's scale), so the product reads what the solvers read. threads: OpenMP threads
  // of the build.
  RowBlockMatrix(const FFMatrixView& F, const std::vector<int32_t>& rows, int threads);

  size_t n() const { return n_; }
  size_t blocks() const { return seg_start_.size() - 1; }
  FFValues values() const { return values_; }
  double scale() const { return scale_; }
  size_t columns() const { return size_t(col_start_.back()); }  // block columns held, kBlockRows values each
  size_t nonzeros() const { return nonzeros_; }                 // of them, the values not 0
  double bytes() const;                                         // what it holds

  // Block b: segments seg_start(b) .. seg_start(b + 1), its columns' values from column col_start(b) on.
  int64_t seg_start(size_t b) const { return seg_start_[b]; }
  int64_t col_start(size_t b) const { return col_start_[b]; }
  const BlockSegment* segments() const { return seg_.data(); }
  const int64_t* col_starts() const { return col_start_.data(); }
  // The stored values, kBlockRows a column: float for float32, uint16_t bits otherwise.
  const void* data() const { return values_ == FFValues::float32 ? static_cast<const void*>(f32_.data()) : u16_.data(); }

 private:
  size_t n_ = 0, nonzeros_ = 0;
  FFValues values_ = FFValues::float32;
  double scale_ = 1;
  std::vector<int64_t> seg_start_, col_start_;
  std::vector<BlockSegment> seg_;
  std::vector<float> f32_;
  std::vector<uint16_t> u16_;
};

}  // namespace radiosity
