#include "radiosity/solve/storage/ff_matrix.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/errors.hpp"
#include "radiosity/solve/storage/half.hpp"

namespace radiosity {
namespace {

bool is_kept(float f, double threshold) { return !(std::fabs(double(f)) <= threshold); }  // NaN is kept

// The power of two 2^k (k >= 0) that brings the largest |F_ij| closest to half's maximum 65504 without passing it.
double half_scale_up(float biggest) {
  if (biggest == 0) return 1;
  const int k = static_cast<int>(std::floor(std::log2(65504.0 / biggest)));
  return std::ldexp(1.0, std::clamp(k, 0, 40));
}

// Calls emit(step, length) for each run of the row Fi (n columns), in order, as the runs storage holds it
// (ff_matrix.hpp): kept columns joined across gaps of at most o.merge_gap, bridges over gaps above o.max_step, runs
// longer than o.max_length (or o.max_step) split. Shared by count_runs and the matrix, so that both count the same
// runs.
template <class Emit>
void row_runs(const float* Fi, size_t n, const FFMatrixOptions& o, Emit&& emit) {
  const double threshold = o.threshold;
  const size_t merge_gap = o.merge_gap, max_step = o.max_step, max_length = std::min(o.max_step, o.max_length);
  size_t end = 0;  // the column after the previous run's last
  for (size_t j = 0; j < n;) {
    if (!is_kept(Fi[j], threshold)) {
      ++j;
      continue;
    }
    const size_t first = j;
    size_t last = j;
    for (size_t q = j + 1; q < n && q - last - 1 <= merge_gap; ++q)
      if (is_kept(Fi[q], threshold)) last = q;
    j = last + 1;
    size_t gap = first - end;
    for (; gap > max_step; gap -= max_step) emit(max_step, size_t{0});
    size_t step = gap;
    for (size_t left = last + 1 - first; left > 0; step = 0) {
      const size_t piece = std::min(left, max_length);
      emit(step, piece);
      left -= piece;
    }
    end = last + 1;
  }
}

}  // namespace

float largest_abs(const float* F, size_t count) {
  float biggest = 0;
#pragma omp parallel for reduction(max : biggest) schedule(static)
  for (size_t k = 0; k < count; ++k)
    if (std::isfinite(F[k])) biggest = std::max(biggest, std::fabs(F[k]));
  return biggest;
}

const char* to_string(FFStorage s) {
  switch (s) {
    case FFStorage::dense: return "dense";
    case FFStorage::csr: return "csr";
    case FFStorage::compressed: return "compressed";
    case FFStorage::runs: return "runs";
  }
  return "unknown";
}

const char* to_string(FFValues v) {
  switch (v) {
    case FFValues::float32: return "float32";
    case FFValues::float16: return "float16";
    case FFValues::bfloat16: return "bfloat16";
  }
  return "unknown";
}

FFStorage parse_ff_storage(const std::string& s) {
  if (s == "dense") return FFStorage::dense;
  if (s == "csr") return FFStorage::csr;
  if (s == "compressed") return FFStorage::compressed;
  if (s == "runs") return FFStorage::runs;
  throw hpcgi::UsageError("unknown form-factor storage '" + s + "' (known: dense, csr, compressed, runs)");
}

FFValues parse_ff_values(const std::string& s) {
  if (s == "float32") return FFValues::float32;
  if (s == "float16") return FFValues::float16;
  if (s == "bfloat16") return FFValues::bfloat16;
  throw hpcgi::UsageError("unknown form-factor precision '" + s + "' (known: float32, float16, bfloat16)");
}

size_t value_bytes(FFValues v) { return v == FFValues::float32 ? 4 : 2; }

FFMatrixView dense_float32_view(const float* F, size_t n) {
  FFMatrixView v;
  v.n = n;
  v.data = F;
  return v;
}

std::vector<int32_t> dense_rows_to_compute(const std::vector<Rgb>& reflectivity) {
  if (std::all_of(reflectivity.begin(), reflectivity.end(), row_needed)) return {};
  std::vector<int32_t> rows;
  for (size_t i = 0; i < reflectivity.size(); ++i)
    if (row_needed(reflectivity[i])) rows.push_back(static_cast<int32_t>(i));
  return rows;
}

size_t count_kept(const float* F, size_t n, const std::vector<Rgb>& reflectivity, double threshold,
                  size_t row_begin, size_t row_end) {
  size_t count = 0;
  const size_t last = std::min(row_end, n);
#pragma omp parallel for reduction(+ : count) schedule(static)
  for (size_t i = row_begin; i < last; ++i) {
    if (!row_needed(reflectivity[i])) continue;
    const float* Fi = F + (i - row_begin) * n;
    for (size_t j = 0; j < n; ++j) count += is_kept(Fi[j], threshold);
  }
  return count;
}

size_t count_bridges(const float* F, size_t n, const std::vector<Rgb>& reflectivity, double threshold,
                     size_t row_begin, size_t row_end, uint32_t max_step) {
  if (n <= size_t(max_step) + 1) return 0;  // no step can exceed max_step
  size_t count = 0;
  const size_t last = std::min(row_end, n);
#pragma omp parallel for reduction(+ : count) schedule(static)
  for (size_t i = row_begin; i < last; ++i) {
    if (!row_needed(reflectivity[i])) continue;
    const float* Fi = F + (i - row_begin) * n;
    int64_t prev = -1;
    for (size_t j = 0; j < n; ++j)
      if (is_kept(Fi[j], threshold)) {
        count += size_t(int64_t(j) - prev - 1) / max_step;
        prev = int64_t(j);
      }
  }
  return count;
}

RunCounts count_runs(const float* F, size_t n, const std::vector<Rgb>& reflectivity, const FFMatrixOptions& opt,
                     size_t row_begin, size_t row_end) {
  size_t runs = 0, entries = 0;
  const size_t last = std::min(row_end, n);
#pragma omp parallel for reduction(+ : runs, entries) schedule(static)
  for (size_t i = row_begin; i < last; ++i) {
    if (!row_needed(reflectivity[i])) continue;
    row_runs(F + (i - row_begin) * n, n, opt, [&](size_t, size_t length) {
      ++runs;
      entries += length;
    });
  }
  return {runs, entries};
}

double ff_storage_bytes(FFStorage storage, FFValues values, size_t n, size_t kept, size_t bridges,
                        const RunCounts& runs) {
  const double v = double(value_bytes(values));
  switch (storage) {
    case FFStorage::dense: return v * double(n) * double(n);
    case FFStorage::csr: return double(kept) * (v + sizeof(int32_t)) + sizeof(int64_t) * double(n + 1);
    case FFStorage::compressed:
      return double(kept + bridges) * (v + sizeof(uint16_t)) + sizeof(int64_t) * double(n + 1);
    case FFStorage::runs:
      return double(runs.entries) * v + double(runs.runs) * sizeof(FFRun) + 2 * sizeof(int64_t) * double(n + 1);
  }
  return 0;
}

size_t apply_threshold(float* F, size_t n, double threshold, size_t rows) {
  size_t nonzero = 0;
  const size_t count = std::min(rows, n) * n;
#pragma omp parallel for reduction(+ : nonzero) schedule(static)
  for (size_t k = 0; k < count; ++k) {
    if (!is_kept(F[k], threshold)) F[k] = 0;
    nonzero += F[k] != 0;
  }
  return nonzero;
}

namespace {

// The options and sizes a matrix can be built with; a UsageError for the first that it cannot.
void check_matrix_options(const FFMatrixOptions& opt, size_t n, size_t reflectivity_size) {
  if (opt.max_step < 1 || opt.max_step > kMaxStep)
    throw hpcgi::UsageError("form-factor matrix: a compressed step must lie in 1.." + std::to_string(kMaxStep));
  if (opt.max_length < 1 || opt.max_length > kMaxStep)
    throw hpcgi::UsageError("form-factor matrix: a run's length must lie in 1.." + std::to_string(kMaxStep));
  if (!(opt.threshold >= 0 && std::isfinite(opt.threshold)))
    throw hpcgi::UsageError("form-factor threshold must be finite and >= 0");
  if (reflectivity_size != n) throw hpcgi::UsageError("form-factor matrix: reflectivity of the wrong size");
  if (n > size_t(std::numeric_limits<int32_t>::max()))
    throw hpcgi::UsageError("form-factor matrix: " + std::to_string(n) + " patches exceed int32 column indices");
}

}  // namespace

FormFactorMatrix::FormFactorMatrix(const float* F, size_t n, const std::vector<Rgb>& reflectivity,
                                   const FFMatrixOptions& opt, size_t row_begin, size_t row_end)
    : n_(n), opt_(opt) {
  check_matrix_options(opt, n, reflectivity.size());
  const size_t r0 = std::min(row_begin, n), r1 = std::max(r0, std::min(row_end, n));
  row_begin_ = r0;
  row_end_ = r1;
  const size_t values = (r1 - r0) * n;  // F's values: rows r0..r1, row i at F + (i - r0)·n
  const double up =
      opt.values == FFValues::float16 ? half_scale_up(opt.largest >= 0 ? opt.largest : largest_abs(F, values)) : 1.0;
  scale_ = 1 / up;
  auto store = [&](size_t k, float f) {  // the value f at position k of the stored values, rounded once
    switch (opt_.values) {
      case FFValues::float32: f32_[k] = f; break;
      case FFValues::float16: u16_[k] = float_to_half(float(double(f) * up)); break;
      case FFValues::bfloat16: u16_[k] = float_to_bfloat16(f); break;
    }
  };
  auto allocate = [&](size_t count) {
    if (opt_.values == FFValues::float32)
      f32_.resize(count);
    else
      u16_.resize(count);
  };
  if (opt.storage == FFStorage::dense)
    build_dense(F, values, store, allocate);
  else if (opt.storage == FFStorage::runs)
    build_runs(F, reflectivity, r0, r1, store, allocate);
  else
    build_entries(F, reflectivity, r0, r1, store, allocate);
}

// The dense storage: F's values rows r0..r1 (`values` of them), those not kept as 0.
template <class Store, class Allocate>
void FormFactorMatrix::build_dense(const float* F, size_t values, Store& store, Allocate& allocate) {
  const FFMatrixOptions& opt = opt_;
  allocate(values);
#pragma omp parallel for schedule(static)
  for (size_t k = 0; k < values; ++k) store(k, is_kept(F[k], opt.threshold) ? F[k] : 0.0f);
  size_t nonzero = 0;
#pragma omp parallel for reduction(+ : nonzero) schedule(static)
  for (size_t k = 0; k < values; ++k) nonzero += is_kept(F[k], opt.threshold) && F[k] != 0;
  kept_ = nonzero;
}

// CSR and compressed in two passes: the entries per row (kept values, and bridges for compressed), their prefix
// sums as row starts, then the entries in place. Rows [r0, r1) are F's, row i at F + (i - r0)·n.
template <class Store, class Allocate>
void FormFactorMatrix::build_entries(const float* F, const std::vector<Rgb>& reflectivity, size_t r0, size_t r1,
                                     Store& store, Allocate& allocate) {
  const size_t n = n_;
  const FFMatrixOptions& opt = opt_;
  const bool steps = opt.storage == FFStorage::compressed;
  row_start_.assign(n + 1, 0);
  size_t bridges = 0;
#pragma omp parallel for schedule(static) reduction(+ : bridges)
  for (size_t i = r0; i < r1; ++i) {
    size_t count = 0, row_bridges = 0;
    if (row_needed(reflectivity[i])) {
      const float* Fi = F + (i - r0) * n;
      int64_t prev = -1;
      for (size_t j = 0; j < n; ++j)
        if (is_kept(Fi[j], opt.threshold)) {
          ++count;
          if (steps) row_bridges += size_t(int64_t(j) - prev - 1) / opt.max_step;
          prev = int64_t(j);
        }
    }
    row_start_[i + 1] = static_cast<int64_t>(count + row_bridges);
    bridges += row_bridges;
  }
  for (size_t i = 0; i < n; ++i) row_start_[i + 1] += row_start_[i];
  bridges_ = bridges;
  kept_ = static_cast<size_t>(row_start_[n]) - bridges;
  const size_t entries = static_cast<size_t>(row_start_[n]);
  allocate(entries);
  if (steps)
    step_.resize(entries);
  else
    col_.resize(entries);
#pragma omp parallel for schedule(dynamic, 16)
  for (size_t i = r0; i < r1; ++i) {
    size_t k = static_cast<size_t>(row_start_[i]);
    if (k == static_cast<size_t>(row_start_[i + 1])) continue;
    const float* Fi = F + (i - r0) * n;
    int64_t prev = -1;
    for (size_t j = 0; j < n; ++j) {
      if (!is_kept(Fi[j], opt.threshold)) continue;
      if (steps) {
        for (; int64_t(j) - prev > int64_t(opt.max_step); prev += opt.max_step) {  // a bridge: value 0
          store(k, 0.0f);
          step_[k++] = uint16_t(opt.max_step);
        }
        store(k, Fi[j]);
        step_[k++] = uint16_t(int64_t(j) - prev);
        prev = int64_t(j);
      } else {
        store(k, Fi[j]);
        col_[k++] = static_cast<int32_t>(j);
      }
    }
  }
}

// The runs storage in two passes, as csr's: each row's runs and values (row_runs), their prefix sums as the row
// starts, then the runs and values in place (kRunValuePad zeros past the last value). Rows [r0, r1) are F's, row i
// at F + (i - r0)·n; the others are left empty.
template <class Store, class Allocate>
void FormFactorMatrix::build_runs(const float* F, const std::vector<Rgb>& reflectivity, size_t r0, size_t r1,
                                  Store& store, Allocate& allocate) {
  const size_t n = n_;
  const FFMatrixOptions& o = opt_;
  row_start_.assign(n + 1, 0);
  run_start_.assign(n + 1, 0);
  size_t kept = 0, bridges = 0;
#pragma omp parallel for schedule(static) reduction(+ : kept, bridges)
  for (size_t i = r0; i < r1; ++i) {
    if (!row_needed(reflectivity[i])) continue;
    const float* Fi = F + (i - r0) * n;
    size_t runs = 0, entries = 0;
    row_runs(Fi, n, o, [&](size_t, size_t length) {
      ++runs;
      entries += length;
      bridges += length == 0;
    });
    for (size_t j = 0; j < n; ++j) kept += is_kept(Fi[j], o.threshold);
    row_start_[i + 1] = int64_t(entries);
    run_start_[i + 1] = int64_t(runs);
  }
  for (size_t i = 0; i < n; ++i) {
    row_start_[i + 1] += row_start_[i];
    run_start_[i + 1] += run_start_[i];
  }
  kept_ = kept;
  bridges_ = bridges;
  allocate(size_t(row_start_[n]) + kRunValuePad);
  for (size_t k = size_t(row_start_[n]); k < size_t(row_start_[n]) + kRunValuePad; ++k) store(k, 0.0f);
  run_.resize(size_t(run_start_[n]));
#pragma omp parallel for schedule(dynamic, 16)
  for (size_t i = r0; i < r1; ++i) {
    size_t k = size_t(row_start_[i]), r = size_t(run_start_[i]), j = 0;
    if (r == size_t(run_start_[i + 1])) continue;
    const float* Fi = F + (i - r0) * n;
    row_runs(Fi, n, o, [&](size_t step, size_t length) {
      run_[r++] = FFRun{uint16_t(step), uint16_t(length)};
      j += step;
      for (size_t q = 0; q < length; ++q, ++j) store(k++, is_kept(Fi[j], o.threshold) ? Fi[j] : 0.0f);
    });
  }
}

FormFactorMatrix::FormFactorMatrix(Parts&& p)
    : n_(p.n), kept_(p.kept), bridges_(p.bridges), opt_(p.opt), scale_(p.scale), f32_(std::move(p.f32)),
      u16_(std::move(p.u16)), row_start_(std::move(p.row_start)), col_(std::move(p.col)), step_(std::move(p.step)),
      run_start_(std::move(p.run_start)), run_(std::move(p.run)) {
  row_begin_ = std::min(p.row_begin, n_);
  row_end_ = std::max(row_begin_, std::min(p.row_end, n_));
}

FFMatrixView FormFactorMatrix::view() const {
  FFMatrixView v;
  v.n = n_;
  v.storage = opt_.storage;
  v.values = opt_.values;
  v.data = opt_.values == FFValues::float32 ? static_cast<const void*>(f32_.data()) : u16_.data();
  if (opt_.storage != FFStorage::dense) {
    v.row_start = row_start_.data();
    v.col = opt_.storage == FFStorage::csr ? col_.data() : nullptr;
    v.step = opt_.storage == FFStorage::compressed ? step_.data() : nullptr;
    v.run_start = opt_.storage == FFStorage::runs ? run_start_.data() : nullptr;
    v.run = opt_.storage == FFStorage::runs ? run_.data() : nullptr;
  }
  v.scale = scale_;
  return v;
}

RunCounts FormFactorMatrix::runs() const {
  if (opt_.storage != FFStorage::runs) return {};
  return {run_.size(), size_t(row_start_[n_])};
}

double FormFactorMatrix::bytes() const {
  return ff_storage_bytes(opt_.storage, opt_.values, n_, kept_, bridges_, runs());
}

}  // namespace radiosity
