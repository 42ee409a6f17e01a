#include "radiosity/app/solve_load.hpp"

#include <cstdio>
#include <utility>

#include "common/comm.hpp"
#include "common/errors.hpp"
#include "common/memory.hpp"
#include "common/timer.hpp"
#include "radiosity/solve/storage_choice.hpp"

namespace radiosity::app {
namespace {

void mesh_of(const SolvePlan& p, Loaded& L) {
  L.m = hpcgi::comm::agreed([&] {
    Mesh mesh = load_scene(p.scene, &L.load_s);
    require_rows_for_ranks(mesh.size(), p.dist ? p.ranks : 1);
    return mesh;
  });
  L.n = L.m.size();
  L.n2 = double(L.n) * double(L.n);
  L.patches = std::to_string(L.n) + " patches";
}

// The plan's header of --ff checked against the mesh (not read again). A sparse file (version 2) is read as it is
// stored, never dense (radiosity/formfactor/file/sparse.hpp). What is no file at all is taken for a dense one here (the memory check
// refuses it from the patch count, the load by what it is).
void read_file_info(const SolvePlan& p, Loaded& L) {
  hpcgi::comm::agreed([&] {
    if (p.file) L.file = p.file->checked(L.m);
  });
  if (L.file) L.file_info = L.file->info();
  L.sparse_file = L.file_info.version != 1;
}

// What a process holds of a solve, in words: the file's values, their 16-bit copy, the vectors, the picture.
std::string held_in_words(const SolvePlan& p, const Loaded& L, double copy_bytes, double picture_bytes) {
  const std::string values = L.sparse_file ? L.file_info.storage + " " + L.file_info.precision : "dense float32";
  const std::string rows =
      p.dist ? "of rank " + std::to_string(p.rank) + "'s " + std::to_string(L.block.rows()) + " rows " : "";
  return "the form-factor file's " + values + " values " + rows + gib(L.file_bytes) +
         (copy_bytes > 0 ? ", their 16-bit copy " + gib(copy_bytes) : "") + ", vectors " + gib(vector_bytes(L.n)) +
         (picture_bytes > 0 ? ", the picture " + gib(picture_bytes) : "");
}

// Memory: the file's dense float32 values (always read whole; on MPI ranks each its block of rows), or a sparse
// file's matrix, a 16-bit dense copy, the vectors; a CSR copy is checked once its size is known (the kept values
// are counted after loading). --max-memory-per-rank is checked first, the same on every rank (the split depends
// on the mesh only).
void check_memory(const SolvePlan& p, Loaded& L) {
  const size_t n = L.n;
  const bool dense16 = p.storage == FFStorage::dense && p.values != FFValues::float32, sparse = L.sparse_file;
  const double sparse_bytes = double(L.file_info.payload_bytes);
  // On MPI ranks, rows in blocks of equal count: a rank holds every row of its block, dense, so equal counts balance
  // the memory, which decides how many ranks a scene needs. Rows of reflectivity 0 are held but not computed; the
  // compute can be off balance by at most their share (lights, usually a few percent).
  const std::vector<uint64_t> row_work(n, 1);
  // Rank 0 draws the pictures: an RGB image, its depth buffer and its colour sums (render.cpp), 35 bytes a pixel.
  const double picture_bytes = (p.png.empty() && p.snapshots.empty()) ? 0.0 : 35.0 * double(p.width) * double(p.height);
  const NeedsAt needs = [&](int ranks) {
    const std::vector<size_t> b = dist::split_by_work(row_work, ranks);  // ranks > 1 for a serial run: what mpi would hold
    std::vector<RankNeed> v;
    for (int r = 0; r < ranks; ++r) {
      const size_t rows = b[r + 1] - b[r];
      v.push_back({rows, sparse ? sparse_bytes : (4.0 + (dense16 ? 2.0 : 0.0)) * double(rows) * double(n),
                   vector_bytes(n) + (r == 0 ? picture_bytes : 0)});
    }
    return v;
  };
  const std::vector<size_t> bounds = p.dist ? dist::split_by_work(row_work, p.ranks) : std::vector<size_t>{0, n};
  L.block = dist::block_of(bounds, p.dist ? p.rank : 0);
  require_memory_per_rank(p.limit, needs, p.ranks, "a solve of " + L.patches, "bin/radiosity solve ... --backend mpi");
  if (p.dist) L.rank_needs = needs(p.ranks);
  L.file_bytes = sparse ? sparse_bytes : 4.0 * double(L.block.rows()) * double(n);
  const double copy_bytes = dense16 ? 2 * L.n2 : 0, picture = p.root ? picture_bytes : 0;
  hpcgi::comm::agreed([&] {
    hpcgi::require_host_memory("a solve of " + L.patches + " (" + held_in_words(p, L, copy_bytes, picture) + ")",
                               L.file_bytes + copy_bytes + vector_bytes(n) + picture);
  });
}

// The file's values as stored, in the one matrix: a sparse file's, an MPI rank's block of rows (its read's times
// added to the rank's), or every row. The header read once (by the plan) is not read again.
void read_rows(const SolvePlan& p, Loaded& L, const dist::RowBlock& block) {
  FormFactorRead how;
  dist::FileStats st;
  if (p.dist) {
    how.rank_rows = true;
    how.rows = block;
    how.stats = &st;
  }
  L.matrix = std::make_unique<FormFactorMatrix>(read_form_factors(*L.file, L.m, how));
  L.rank_read_s += st.io_s;
  L.rank_checksum_s += st.checksum_s;
  L.rank_chain_s += st.chain_s;
}

// The load's first read of the file's values; the memory check (check_memory) has passed.
void read_values(const SolvePlan& p, Loaded& L) {
  hpcgi::Timer t;
  if (!L.file)  // no file: refused here by what it is, as every reader refuses it
    hpcgi::comm::agreed([&] {
      FormFactorFile::open(p.ff);
      throw hpcgi::UsageError("--ff '" + p.ff + "': not a form-factor file");
    });
  L.params = L.file_info.params;
  read_rows(p, L, L.block);
  L.ff_load_s = t.seconds();
  static const float kNoRows = 0;  // a rank without rows still has a matrix (of none of them)
  FFMatrixView view = L.matrix->view();
  if (!view.data && view.storage == FFStorage::dense) view.data = &kNoRows;
  L.sys = make_system(L.m, view);
  if (p.dist) {
    L.sys.rows_begin = L.block.begin;
    L.sys.rows_end = L.block.end;
  }
}

// The file's dense float32 values (this process's rows), or null for a sparse file.
const float* file_values(const Loaded& L) { return L.sparse_file ? nullptr : dense_float32(L.sys); }

// The dense file's values in the run's storage and precision (the dense values are given back).
void convert_dense(const SolvePlan& p, Loaded& L, size_t bridges, const RunCounts& runs) {
  const double bytes = ff_storage_bytes(L.storage, p.values, L.n, L.kept, bridges, runs);
  // The dense file's values and the copy are held at once while it is built: that is what the limit must allow.
  const double held = L.file_bytes + bytes + vector_bytes(L.n);
  if (p.limit > 0 && held > p.limit)
    throw hpcgi::UsageError("a solve of " + L.patches + " holds " + gib(held) + " while its " + to_string(L.storage) +
                            " " + to_string(p.values) + " form factors (" + gib(bytes) +
                            ") are built from the dense file (" + gib(L.file_bytes) + "), more than "
                            "--max-memory-per-rank " + gib(p.limit) + ": write the file with formfactors --storage " +
                            to_string(L.storage == FFStorage::dense ? FFStorage::compressed : L.storage) +
                            " (then only those are held)");
  hpcgi::require_host_memory("the " + std::string(to_string(L.storage)) + " " + to_string(p.values) +
                                 " form factors of " + L.patches + " (" + std::to_string(L.kept) + " kept)",
                             bytes);
  FFMatrixOptions opt;
  opt.storage = L.storage;
  opt.values = p.values;
  opt.threshold = p.threshold;
  // The dense values are no longer needed once the run's matrix is built: replacing the one matrix gives them back.
  L.matrix = std::make_unique<FormFactorMatrix>(file_values(L), L.n, L.sys.reflectivity, opt);
  L.sys.matrix = L.matrix->view();
}

#ifdef HAVE_MPI
// A csr, compressed or runs rank's rows balanced by their cost in the product (ff_matrix.hpp's: its entries and
// kRowCost; runs: and kRunCost a run, ff_matrix.hpp), not by count: the rows are counted in the blocks of equal
// count that were read, the ranks' counts summed, the blocks split again, and each rank reads its new block (the
// file a second time; the first block is freed before). --max-memory-per-rank is checked again here on the new
// blocks: the dense rows a rank reads and its matrix (ff_storage_bytes) are held at once while it is built.
void balance_rows_by_cost(const SolvePlan& p, Loaded& L, const FFMatrixOptions& opt) {
  const size_t n = L.n;
  const std::vector<uint64_t> counts =
      row_entries(file_values(L), n, L.sys.reflectivity, opt, L.block.begin, L.block.end);
  const std::vector<uint64_t> work = row_costs(counts);
  const NeedsAt needs = [&](int ranks) {
    const std::vector<size_t> b = dist::split_by_work(work, ranks);
    std::vector<RankNeed> out;
    for (int r = 0; r < ranks; ++r) {
      uint64_t entries = 0, runs = 0;
      for (size_t i = b[r]; i < b[r + 1]; ++i) {
        entries += counts[i];
        runs += counts[n + i];
      }
      const double matrix = ff_storage_bytes(opt.storage, opt.values, n, entries, 0, RunCounts{runs, entries});
      const double dense = 4.0 * double(b[r + 1] - b[r]) * double(n);  // read, and held while it is built
      out.push_back({b[r + 1] - b[r], matrix, dense + vector_bytes(n)});
    }
    return out;
  };
  require_memory_per_rank(p.limit, needs, p.ranks,
                          "a solve of " + L.patches + " in " + to_string(L.storage) + " " + to_string(p.values),
                          "bin/radiosity solve ... --backend mpi");
  L.rank_needs = needs(p.ranks);
  const dist::RowBlock block = dist::block_of(dist::split_by_work(work, p.ranks), p.rank);
  if (block.begin != L.block.begin || block.end != L.block.end) {
    L.matrix.reset();  // the rows read before: counted, no longer needed
    read_rows(p, L, block);
    L.sys.matrix = L.matrix->view();
    L.block = block;
  }
}

// Backend mpi in a storage other than dense float32: each rank's rows in that storage, built from the dense file's
// rows (a sparse storage's rows balanced first: balance_rows_by_cost). The float16 scale is every rank's largest
// value, so that every rank rounds as one process.
void build_rank_matrix(const SolvePlan& p, Loaded& L) {
  const size_t n = L.n;
  FFMatrixOptions opt;
  opt.storage = L.storage;
  opt.values = p.values;
  opt.threshold = p.threshold;
  opt.largest = float(hpcgi::comm::max(double(largest_abs(file_values(L), L.block.rows() * n))));
  if (L.storage != FFStorage::dense) balance_rows_by_cost(p, L, opt);
  L.matrix = hpcgi::comm::agreed([&] {  // the rank's dense rows are given back as the one matrix is replaced
    return std::make_unique<FormFactorMatrix>(file_values(L), n, L.sys.reflectivity, opt, L.block.begin,
                                              L.block.end);
  });
  L.sys.matrix = L.matrix->view();
  L.sys.rows_begin = L.block.begin;
  L.sys.rows_end = L.block.end;
  double bytes = L.matrix->bytes();
  hpcgi::comm::sum(&bytes, 1);
  L.matrix_storage_bytes = bytes;  // all ranks together
}
#endif

// The storage the run takes and what it keeps (counted on the file's values), and so whether the run's matrix is the
// file's values as read.
void choose(const SolvePlan& p, Loaded& L) {
  hpcgi::Timer t;
  const StorageChoice c = L.sparse_file ? stored_storage(*L.matrix)
                                        : choose_storage(file_values(L), L.n, L.sys.reflectivity, p.threshold,
                                                         *p.backend, p.values, p.storage, L.block.begin, L.block.end);
  L.storage = c.storage;
  L.kept = c.kept;
  L.dropped = c.dropped;
  L.bridges = c.bridges;
  L.runs = c.runs;
  L.same_matrix = L.sparse_file || (p.values == FFValues::float32 && !L.dropped);
  L.choose_s = t.seconds();
}

// The run's form factors: threshold, storage and precision, as chosen.
void build(const SolvePlan& p, Loaded& L) {
  hpcgi::Timer t;
  const bool dropped = L.dropped;
  const size_t bridges = L.bridges;
  const RunCounts& runs = L.runs;
  const bool as_file = L.storage == FFStorage::dense && p.values == FFValues::float32;
  L.matrix_storage_bytes = 4 * L.n2;  // all ranks together
  if (as_file) {
    if (dropped) apply_threshold(L.matrix->dense_float32_values(), L.n, p.threshold, L.block.rows());
  } else if (L.sparse_file) {
    L.matrix_storage_bytes = L.matrix->bytes();
  } else if (p.dist) {
#ifdef HAVE_MPI
    build_rank_matrix(p, L);
#endif
  } else {
    convert_dense(p, L, bridges, runs);
    L.matrix_storage_bytes = L.matrix->bytes();
  }
  size_t rows_without_reflection = 0;
  for (const Rgb& rho : L.sys.reflectivity) rows_without_reflection += !row_needed(rho);
  // The backends that read any storage skip those rows, and mpi (the same product), and a sparse storage holds none
  // of them; the others compute them.
  L.skipped_rows =
      p.backend->any_storage || p.backend->distributed || L.storage != FFStorage::dense ? rows_without_reflection : 0;
  if (p.backend->rrv_loop)  // RRV's cache lines: a (pointer, float) pair of 16 bytes per kept value, at most
    hpcgi::require_host_memory("backend original's cache lines for " + L.patches,
                               16.0 * (double(L.kept) + double(rows_without_reflection) * double(L.n)));
  L.ff_build_s = L.choose_s + t.seconds();
}

}  // namespace

std::string gib(double bytes) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f GiB", bytes / (1 << 30));
  return buf;
}

double vector_bytes(size_t n) { return (2 * (8 + 2) * 3 * 8 + 8 * 3 * 8) * double(n); }

Loaded load_mesh(const SolvePlan& p) {
  Loaded L;
  mesh_of(p, L);
  return L;
}

Loaded read_form_factors(const SolvePlan& p, Loaded&& mesh) {
  Loaded L = std::move(mesh);
  read_file_info(p, L);
  check_memory(p, L);
  read_values(p, L);
  choose(p, L);
  return L;
}

Loaded build_matrix(const SolvePlan& p, Loaded&& read) {
  Loaded L = std::move(read);
  build(p, L);
  return L;
}

Loaded load_solve(const SolvePlan& p) { return build_matrix(p, read_form_factors(p, load_mesh(p))); }

}  // namespace radiosity::app
