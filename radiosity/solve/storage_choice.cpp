#include "radiosity/solve/storage_choice.hpp"

#include <algorithm>
#include <stdexcept>

namespace radiosity {

double step_bytes(FFStorage storage, FFValues values, const StorageCounts& c) {
  if (storage == FFStorage::dense) return double(value_bytes(values)) * double(c.n) * double(c.rows_needed);
  if (storage == FFStorage::runs && c.runs.entries < c.kept)  // a run holds every kept value: not counted
    throw std::invalid_argument("step_bytes: the runs of " + std::to_string(c.kept) + " kept values are not counted");
  return ff_storage_bytes(storage, values, c.n, c.kept, c.bridges, c.runs);
}

std::vector<FFStorage> readable_storages(const SolveBackend& b, FFValues values) {
  std::vector<FFStorage> v;
  for (FFStorage s : {FFStorage::dense, FFStorage::csr, FFStorage::compressed, FFStorage::runs})
    if (reads_storage(b, s, values)) v.push_back(s);
  return v;
}

FFStorage fewest_bytes_storage(const std::vector<FFStorage>& readable, FFValues values, const StorageCounts& c) {
  const bool dense = std::find(readable.begin(), readable.end(), FFStorage::dense) != readable.end();
  FFStorage best = dense ? FFStorage::dense : readable.front();
  double least = dense ? kSparseShare * step_bytes(best, values, c) : step_bytes(best, values, c);
  for (FFStorage s : readable)
    if (s != FFStorage::dense && step_bytes(s, values, c) < least) {
      best = s;
      least = step_bytes(s, values, c);
    }
  return best;
}

StorageCounts count_storages(const float* F, size_t n, const std::vector<Rgb>& reflectivity, double threshold,
                             const std::vector<FFStorage>& readable, size_t row_begin, size_t row_end) {
  auto reads = [&](FFStorage s) { return std::find(readable.begin(), readable.end(), s) != readable.end(); };
  const size_t last = std::min(row_end, n);
  StorageCounts c;
  c.n = n;
  c.kept = count_kept(F, n, reflectivity, threshold, row_begin, last);
  for (size_t i = row_begin; i < last; ++i) c.rows_needed += row_needed(reflectivity[i]);
  if (reads(FFStorage::compressed)) c.bridges = count_bridges(F, n, reflectivity, threshold, row_begin, last);
  if (reads(FFStorage::runs)) {
    FFMatrixOptions opt;  // runs: the default merge gap, run length and largest step
    opt.threshold = threshold;
    c.runs = count_runs(F, n, reflectivity, opt, row_begin, last);
  }
  return c;
}

}  // namespace radiosity
