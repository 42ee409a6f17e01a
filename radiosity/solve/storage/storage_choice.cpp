#include "radiosity/solve/storage/storage_choice.hpp"

namespace radiosity {

double step_bytes(FFStorage storage, FFValues values, const StorageCounts& c) {
  if (storage == FFStorage::dense) return double(value_bytes(values)) * double(c.n) * double(c.rows_needed);
  return ff_storage_bytes(storage, values, c.n, c.kept, c.bridges);
}

std::vector<FFStorage> readable_storages(const SolveBackend& b, FFValues values) {
  std::vector<FFStorage> v;
  for (FFStorage s : {FFStorage::dense, FFStorage::csr, FFStorage::compressed})
    if (reads_storage(b, s, values)) v.push_back(s);
  return v;
}

FFStorage fewest_bytes_storage(const std::vector<FFStorage>& readable, FFValues values, const StorageCounts& c) {
  FFStorage best = readable.front();
  double least = step_bytes(best, values, c);
  for (FFStorage s : readable)
    if (step_bytes(s, values, c) < least) {
      best = s;
      least = step_bytes(s, values, c);
    }
  return best;
}

}  // namespace radiosity
