#include "radiosity/solve/storage/storage_choice.hpp"

#include <stdexcept>

namespace radiosity {

double step_bytes(FFStorage storage, FFValues values, const StorageCounts& c) {
  if (storage == FFStorage::dense) return double(value_bytes(values)) * double(c.n) * double(c.rows_needed);
  if (storage == FFStorage::runs && c.runs.entries < c.kept)  // a run holds every kept value: not counted
    throw std::invalid_argument("step_bytes: the runs of " + std::to_string(c.kept) + " kept values are not counted");
  return ff_storage_bytes(storage, values, c.n, c.kept, c.bridges, c.runs);
}

std::vector<FFStorage> readable_storages(const SolveBackend& b) {
  if (b.any_storage) return {FFStorage::dense, FFStorage::csr, FFStorage::compressed, FFStorage::runs};
  return {FFStorage::dense};
}

FFStorage fewest_bytes_storage(const std::vector<FFStorage>& readable, FFValues values, const StorageCounts& c) {
  FFStorage best = FFStorage::dense;
  double least = kSparseShare * step_bytes(best, values, c);
  for (FFStorage s : readable)
    if (s != FFStorage::dense && step_bytes(s, values, c) < least) {
      best = s;
      least = step_bytes(s, values, c);
    }
  return best;
}

}  // namespace radiosity
