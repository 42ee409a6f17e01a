#include "radiosity/solve/storage_choice.hpp"

#include <algorithm>
#include <stdexcept>

#include "common/comm.hpp"

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

StorageChoice choose_storage(const float* F, size_t n, const std::vector<Rgb>& reflectivity, double threshold,
                             const SolveBackend& b, FFValues values, std::optional<FFStorage> asked, size_t row_begin,
                             size_t row_end) {
  const std::vector<FFStorage> readable = readable_storages(b, values);
  const StorageCounts c = count_storages(F, n, reflectivity, threshold, readable, row_begin, row_end);
  uint64_t counts[6] = {c.kept, c.bridges, c.rows_needed, c.runs.runs, c.runs.entries,
                        threshold > 0 ? count_kept(F, n, reflectivity, 0, row_begin, row_end) : c.kept};
  hpcgi::comm::sum(counts, 6);
  StorageChoice s;
  s.kept = size_t(counts[0]);
  s.dropped = threshold > 0 && s.kept != size_t(counts[5]);
  s.bridges = size_t(counts[1]);
  s.runs = RunCounts{size_t(counts[3]), size_t(counts[4])};
  s.storage = asked ? *asked
                    : fewest_bytes_storage(readable, values, StorageCounts{n, s.kept, s.bridges, size_t(counts[2]), s.runs});
  return s;
}

StorageChoice stored_storage(const FormFactorMatrix& stored) {
  StorageChoice s;
  s.storage = stored.view().storage;
  s.kept = stored.kept();
  s.bridges = stored.bridges();
  s.runs = stored.runs();
  return s;
}

std::vector<uint64_t> row_entries(const float* F, size_t n, const std::vector<Rgb>& reflectivity,
                                  const FFMatrixOptions& opt, size_t row_begin, size_t row_end) {
  std::vector<uint64_t> counts(2 * n, 0);
#pragma omp parallel for schedule(dynamic, 64)
  for (size_t i = row_begin; i < row_end; ++i) {
    const float* Fi = F + (i - row_begin) * n;
    if (opt.storage == FFStorage::runs) {
      const RunCounts r = count_runs(Fi, n, reflectivity, opt, i, i + 1);
      counts[i] = r.entries;
      counts[n + i] = r.runs;
    } else {
      counts[i] = count_kept(Fi, n, reflectivity, opt.threshold, i, i + 1) +
                  (opt.storage == FFStorage::compressed ? count_bridges(Fi, n, reflectivity, opt.threshold, i, i + 1)
                                                        : 0);
    }
  }
  hpcgi::comm::sum(counts.data(), int(2 * n));
  return counts;
}

std::vector<uint64_t> row_costs(const std::vector<uint64_t>& entries) {
  const size_t n = entries.size() / 2;
  std::vector<uint64_t> work(n);
  for (size_t i = 0; i < n; ++i) work[i] = entries[i] + kRunCost * entries[n + i] + kRowCost;
  return work;
}

}  // namespace radiosity
