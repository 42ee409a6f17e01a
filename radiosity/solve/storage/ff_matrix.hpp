// The form-factor matrix in the storage a run asks for, so that a run holds and reads only what its scene needs:
//   dense: n×n row-major, every F_ij (the form-factor file's layout, report §3.6);
//   csr:   compressed sparse rows, only the F_ij that are kept (|F_ij| > threshold): values, int32 column indices
//          and int64 row starts. Worth it when a threshold or occlusion leaves most F_ij zero.
//   compressed: csr with each column given as a uint16 step from the previous column of its row (the first from
//          -1), so an entry costs its value and 2 bytes (6 in float32, 4 in 16 bits) against csr's value and 4. A
//          step above 65535 (a gap of more than 65535 zeros: scenes of more than 65536 patches only) is bridged by
//          entries of step 65535 and value 0 ("bridges"), so that values and steps stay one entry each and the
//          kernels read them in lockstep (csr_kernels.hpp).
//   runs:  each row a list of runs of consecutive columns (the patches of one surface are consecutive, and a
//          surface is seen or hidden as a whole, so a row's kept F_ij come in runs: room3 averages 8 per run), each
//          run a uint16 step from the end of the previous run (the row starts at column 0) and a uint16 length, its
//          values contiguous. A gap of at most merge_gap zeros between two runs is stored as zeros inside one run
//          (cheaper than a new run: see kRunMergeGap). An entry costs its value alone plus 4 bytes a run, and the
//          product reads x contiguously (no gathers; runs_kernels.hpp). A gap above max_step takes runs of length
//          0 and step max_step ("bridges"), a run longer than max_length (kRunMaxLength, 16) or max_step is split
//          (the next piece has step 0), so that the product takes a run in one masked block of 16. Rows
//          start twice: row_start into the values, run_start into the runs.
// and the values as
//   float32: the file's values;
//   float16: IEEE half, scaled by a power of two so that the largest |F_ij| is just below half's maximum (65504):
//            a form factor is at most 1, and unscaled every F_ij below half's smallest normal number 6.1e-5 (most
//            of a large scene's) would lose bits or flush to zero. Scaling by 2^k is exact and undone in the sum;
//   bfloat16: float32's exponent with 8 bits of significand (no scaling needed: same range as float32).
// Values are rounded to nearest-even once, when the matrix is built; the kernels widen them to the working
// precision and accumulate there (float32 or float64).
//
// Rows of patches whose reflectivity is 0 in every channel are never needed: B_i = E_i whatever F says. CSR
// and runs leave them empty (neither stored nor read); a dense matrix keeps them (rows stay at i·n) but the kernels skip
// them (dense_rows_to_compute).
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "radiosity/mesh.hpp"

namespace radiosity {

enum class FFStorage { dense, csr, compressed, runs };
enum class FFValues { float32, float16, bfloat16 };

const char* to_string(FFStorage s);
const char* to_string(FFValues v);
// "dense" | "csr" | "compressed" | "runs"; "float32" | "float16" | "bfloat16"; anything else is a UsageError.
FFStorage parse_ff_storage(const std::string& s);
FFValues parse_ff_values(const std::string& s);
size_t value_bytes(FFValues v);

// One run of a runs matrix: columns [end + step, end + step + length), end the column after the previous run's
// last (0 at the row's start). Part of the form-factor file (radiosity/formfactor/file/sparse.hpp).
struct FFRun {
  uint16_t step;
  uint16_t length;
};
static_assert(sizeof(FFRun) == 4, "a run is part of the file format");

// What the kernels read: a view of a matrix owned elsewhere (a FormFactorMatrix, or the form-factor file's dense
// float32 values).
struct FFMatrixView {
  size_t n = 0;
  FFStorage storage = FFStorage::dense;
  FFValues values = FFValues::float32;
  const void* data = nullptr;          // dense: n·n values, row-major; the others: the entries, row after row
  const int64_t* row_start = nullptr;  // csr, compressed, runs: n + 1 offsets into data (and col or step)
  const int32_t* col = nullptr;        // csr: the column of each kept value
  const uint16_t* step = nullptr;      // compressed: each entry's column minus the previous one's (row start: -1)
  const int64_t* run_start = nullptr;  // runs: n + 1 offsets into run
  const FFRun* run = nullptr;          // runs: the runs, row after row
  double scale = 1;                    // F_ij = scale · stored value (float16: 2^-k; 1 otherwise)
};

// Calls fn(k, j) for each entry k of row i of a csr, compressed or runs matrix, j its column (bridges and merged
// zeros included: their value is 0). For the checks and the sweeps that visit a row once; the products' kernels
// (host/csr_kernels.hpp, host/runs_kernels.hpp) are their own loops.
template <class Fn>
inline void for_each_entry(const FFMatrixView& F, size_t i, Fn&& fn) {
  const size_t k0 = size_t(F.row_start[i]), k1 = size_t(F.row_start[i + 1]);
  if (F.storage == FFStorage::csr) {
    for (size_t k = k0; k < k1; ++k) fn(k, size_t(F.col[k]));
    return;
  }
  if (F.storage == FFStorage::runs) {
    size_t k = k0, j = 0;
    for (int64_t r = F.run_start[i]; r < F.run_start[i + 1]; ++r) {
      j += F.run[r].step;
      for (size_t q = 0; q < F.run[r].length; ++q) fn(k++, j++);
    }
    return;
  }
  int64_t j = -1;
  for (size_t k = k0; k < k1; ++k) {
    j += F.step[k];
    fn(k, size_t(j));
  }
}

// The view of n×n dense float32 values (the form-factor file's).
FFMatrixView dense_float32_view(const float* F, size_t n);

// A patch whose row is needed: some channel of its reflectivity is not 0 (NaN counts as not 0, so that a NaN
// reaches the solver and is reported).
inline bool row_needed(const Rgb& reflectivity) {
  return !(reflectivity[0] == 0 && reflectivity[1] == 0 && reflectivity[2] == 0);
}

// The rows a dense matrix's product must compute, increasing; empty when every row is needed (then the kernels
// take their plain path over all rows).
std::vector<int32_t> dense_rows_to_compute(const std::vector<Rgb>& reflectivity);

// The largest column step one compressed entry (or a run) holds; a longer gap takes bridges (see above).
inline constexpr uint32_t kMaxStep = 65535;

// The longest gap of zeros a run stores (runs storage). First measured with a product of two masked blocks of 16 a
// pass and no cap on a run's length (float16, room3 at R = 256, 1 thread, the minimum of 30 products, this
// project's 2-core EPYC VM at load 7): merge gap 2: 991 264 runs, 19.0 M values, 8.09 ms; gap 16: 390 812 runs,
// 23.3 M values, 7.98 ms; so a product cost about a·values + b·runs with a = 0.30 ns and b = 2.3 ns, and merging a
// gap of z zeros paid while z·a < b, z < 8 (gaps 4 and 8 measured 8.2 and 8.5 ms, gap 0 22.6 ms). Measured again
// with runs capped at kRunMaxLength and one block a run (2 threads, every row of room3 needed, medians of 20
// products, alternating, load 0.5-1.1): gap 2 1.96-1.99 ms, gap 4 1.80-1.81 ms, gap 8 1.74-1.82 ms; the bytes
// are fewest near gap 2 (45.2 MB; gap 4 46.5, gap 8 48.7): 4.
inline constexpr uint32_t kRunMergeGap = 4;

// The longest run the runs storage holds: a longer one is split into pieces of at most this many values (each piece
// after the first with step 0), so that the AVX-512 product takes every run in ONE masked block of 16, with no branch
// on its length (runs_kernels.hpp). Files written with longer runs still load: the product takes those in a loop.
inline constexpr uint32_t kRunMaxLength = 16;

// What a run costs in the product, in stored values (the first cost model above: b/a = 2.3/0.3, about 8): backend mpi
// balances a runs matrix's rows between ranks by their stored values, kRunCost a run and kRowCost (below)
// a row (app/solve_load.cpp).
inline constexpr size_t kRunCost = 8;

// A row costs its entries and this many more (its store, its loop's start and end), in entries: what the rows are
// balanced by between threads (host/csr_kernels.hpp) and between MPI ranks (app/solve_load.cpp).
inline constexpr size_t kRowCost = 8;

struct FFMatrixOptions {
  FFStorage storage = FFStorage::dense;
  FFValues values = FFValues::float32;
  double threshold = 0;  // keep F_ij only where |F_ij| > threshold (0: every non-zero)
  uint32_t max_step = kMaxStep;  // compressed, runs: the largest step (and run length) held (smaller: to test bridges)
  uint32_t merge_gap = kRunMergeGap;  // runs: the longest gap of zeros stored inside a run
  uint32_t max_length = kRunMaxLength;  // runs: the longest run stored (a longer one is split, the next piece step 0)
  // float16: the largest |F_ij| the scale is taken from; < 0: that of the rows given. MPI ranks each build their
  // block's matrix from the largest value of all blocks, so that every rank scales alike (as one process would).
  float largest = -1;
};

// A runs matrix's values hold this many zeros past the last (not counted in its bytes), so that the product's
// masked blocks of a run's last 32 values (runs_kernels.hpp) never read past the buffer.
inline constexpr size_t kRunValuePad = 32;

// What a runs matrix of the kept entries holds beyond them: its runs (bridges included) and its stored values (the
// kept ones and the zeros of merged gaps).
struct RunCounts {
  size_t runs = 0, entries = 0;
};

// The largest finite |F_k| of count values (0 when none is).
float largest_abs(const float* F, size_t count);

// Entries kept by the options' threshold in the rows that are needed (what CSR stores), counted in one pass. F may
// hold only rows [row_begin, row_end) (an MPI rank's block, F pointing at its first row): those are counted.
size_t count_kept(const float* F, size_t n, const std::vector<Rgb>& reflectivity, double threshold,
                  size_t row_begin = 0, size_t row_end = SIZE_MAX);

// The bridges a compressed matrix of the kept entries needs with steps of at most max_step, counted as count_kept
// counts (0 when n <= max_step + 1).
size_t count_bridges(const float* F, size_t n, const std::vector<Rgb>& reflectivity, double threshold,
                     size_t row_begin = 0, size_t row_end = SIZE_MAX, uint32_t max_step = kMaxStep);

// The runs a runs matrix of the kept entries takes (opt's merge_gap and max_step), counted as count_kept counts.
RunCounts count_runs(const float* F, size_t n, const std::vector<Rgb>& reflectivity, const FFMatrixOptions& opt,
                     size_t row_begin = 0, size_t row_end = SIZE_MAX);

// Bytes a matrix of these options holds (and one product reads): dense n²·v, csr kept·(v + 4) + 8·(n + 1),
// compressed (kept + bridges)·(v + 2) + 8·(n + 1), runs entries·v + 4·runs + 16·(n + 1), v = value_bytes(values).
double ff_storage_bytes(FFStorage storage, FFValues values, size_t n, size_t kept, size_t bridges = 0,
                        const RunCounts& runs = {});

// Sets every F_ij with |F_ij| <= threshold to 0, in place (a dense float32 run's threshold: no copy of F), in the
// first `rows` rows of F (default: all n; an MPI rank: its block). Returns how many non-zero values stay.
size_t apply_threshold(float* F, size_t n, double threshold, size_t rows = SIZE_MAX);

class FormFactorMatrix {
 public:
  // Its parts as a form-factor file of version 2 holds them (radiosity/formfactor/file/sparse.hpp: the reader checks them).
  struct Parts {
    size_t n = 0, kept = 0, bridges = 0;
    FFMatrixOptions opt;
    double scale = 1;
    std::vector<float> f32;
    std::vector<uint16_t> u16;
    std::vector<int64_t> row_start;
    std::vector<int32_t> col;
    std::vector<uint16_t> step;
    std::vector<int64_t> run_start;
    std::vector<FFRun> run;
    size_t row_begin = 0, row_end = SIZE_MAX;  // dense: the rows f32 holds (an MPI rank's block), row i at (i - row_begin)·n
  };
  explicit FormFactorMatrix(Parts&& p);
  // Built from n×n dense float32 values (a form-factor file's): the options' storage, values and threshold, the
  // rows of patches with reflectivity 0 left empty in csr, compressed and runs. Throws UsageError for n beyond int32
  // column indices. F may hold only rows [row_begin, row_end) (an MPI rank's block, F pointing at its first row):
  // dense keeps those rows (row i at (i - row_begin)·n), csr, compressed and runs index every row (n + 1 row
  // starts, and runs n + 1 run starts) and leave the others empty, so that the kernels address row i alike on every
  // rank (a row's entries and runs are the same as in the whole matrix's).
  FormFactorMatrix(const float* F, size_t n, const std::vector<Rgb>& reflectivity, const FFMatrixOptions& opt,
                   size_t row_begin = 0, size_t row_end = SIZE_MAX);
  FFMatrixView view() const;
  // The rows it holds, [row_begin, row_end) of n: every row, or an MPI rank's block (dense: those rows' values; the
  // sparse storages index every row and leave the others empty).
  size_t row_begin() const { return row_begin_; }
  size_t row_end() const { return row_end_; }
  size_t rows() const { return row_end_ - row_begin_; }
  // Dense float32: its values, rows() × n, to threshold in place (apply_threshold); otherwise null.
  float* dense_float32_values() {
    return opt_.storage == FFStorage::dense && opt_.values == FFValues::float32 ? f32_.data() : nullptr;
  }
  const float* dense_float32_values() const { return const_cast<FormFactorMatrix*>(this)->dense_float32_values(); }
  size_t kept() const { return kept_; }  // values kept (sparse: bridges, merged zeros not counted) or non-zero (dense)
  size_t bridges() const { return bridges_; }  // compressed's bridges, runs' runs of length 0
  RunCounts runs() const;                      // runs: its runs and stored values; otherwise 0

  double bytes() const;                   // what it holds

 private:
  // The constructor's storages (ff_matrix.cpp): dense, csr and compressed, runs.
  template <class Store, class Allocate>
  void build_dense(const float* F, size_t values, Store& store, Allocate& allocate);
  template <class Store, class Allocate>
  void build_entries(const float* F, const std::vector<Rgb>& reflectivity, size_t r0, size_t r1, Store& store,
                     Allocate& allocate);
  template <class Store, class Allocate>
  void build_runs(const float* F, const std::vector<Rgb>& reflectivity, size_t r0, size_t r1, Store& store,
                  Allocate& allocate);

  size_t n_, kept_ = 0, bridges_ = 0, row_begin_ = 0, row_end_ = 0;
  FFMatrixOptions opt_;
  double scale_ = 1;
  std::vector<float> f32_;
  std::vector<uint16_t> u16_;  // float16 or bfloat16 bit patterns
  std::vector<int64_t> row_start_;
  std::vector<int32_t> col_;
  std::vector<uint16_t> step_;
  std::vector<int64_t> run_start_;
  std::vector<FFRun> run_;
};

}  // namespace radiosity
