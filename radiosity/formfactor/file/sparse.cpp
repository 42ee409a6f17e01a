#include "radiosity/formfactor/file/sparse.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <memory>
#include <stdexcept>
#include <vector>

#include "common/errors.hpp"
#include "common/files.hpp"
#include "common/one_line.hpp"
#include "radiosity/formfactor/file/format.hpp"
#include "radiosity/solve/storage/half.hpp"

namespace radiosity {
namespace {

struct Counts {
  uint64_t entries, kept, bridges;
  double scale;
};
static_assert(sizeof(Counts) == 32, "the payload's counts are part of the file format");

size_t index_bytes(FFStorage s) {
  return s == FFStorage::csr ? sizeof(int32_t) : s == FFStorage::compressed ? sizeof(uint16_t) : 0;
}

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};

// The payload of a sparse form-factor file, read in order from just past its header, every byte into the checksum.
class PayloadReader {
 public:
  PayloadReader(const std::string& path, const std::string& file) : file_(file) {
    f_.reset(std::fopen(path.c_str(), "rb"));
    if (!f_ || std::fseek(f_.get(), long(kFormFactorHeaderBytes), SEEK_SET) != 0)
      throw hpcgi::UsageError("cannot read " + file_ + ": " + std::strerror(errno));
  }
  void read(void* dst, size_t bytes) {
    if (bytes > 0 && std::fread(dst, 1, bytes, f_.get()) != bytes)
      throw hpcgi::UsageError("cannot read " + file_ + ": " + std::strerror(errno));
    sum_.update(dst, bytes);
  }
  // The stored checksum after the payload, against the payload's.
  bool checksum_agrees() {
    uint64_t stored = 0;
    if (std::fread(&stored, sizeof stored, 1, f_.get()) != 1)
      throw hpcgi::UsageError("cannot read " + file_ + ": " + std::strerror(errno));
    return stored == sum_.finish();
  }

 private:
  std::string file_;
  std::unique_ptr<std::FILE, FileCloser> f_;
  Fnv64 sum_;
};

using Corrupted = std::function<hpcgi::UsageError(const std::string&)>;

// The payload's counts (and the runs storage's run count), checked against each other and the payload's size.
Counts read_counts(PayloadReader& in, const FormFactorFileInfo& info, const FormFactorMatrix::Parts& p,
                   uint64_t& run_count, const Corrupted& corrupted) {
  Counts c{};
  if (info.payload_bytes < sizeof c) throw corrupted("a payload of " + std::to_string(info.payload_bytes) + " bytes");
  in.read(&c, sizeof c);
  const bool runs = p.opt.storage == FFStorage::runs;
  run_count = 0;
  if (runs && info.payload_bytes >= sizeof c + 8) in.read(&run_count, 8);
  const double want = sparse_payload_bytes(p.opt.storage, p.opt.values, p.n, c.entries, run_count);
  // csr and compressed: every entry a kept value or a bridge; runs: the kept values and merged zeros, bridges are runs
  const bool counts_agree = runs ? c.entries >= c.kept && run_count >= c.bridges : c.entries == c.kept + c.bridges;
  if (!counts_agree || double(info.payload_bytes) != want)
    throw corrupted(std::to_string(c.entries) + " entries (" + std::to_string(c.kept) + " kept, " +
                    std::to_string(c.bridges) + " bridges" + (runs ? ", " + std::to_string(run_count) + " runs" : "") +
                    ") in a payload of " + std::to_string(info.payload_bytes) + " bytes");
  if (!(c.scale > 0 && std::isfinite(c.scale)) || (p.opt.values != FFValues::float16 && c.scale != 1))
    throw corrupted("scale " + std::to_string(c.scale));
  return c;
}

// The row starts, the storage's index (csr's columns, compressed's steps, runs' run starts and runs) and the values.
void read_arrays(PayloadReader& in, FormFactorMatrix::Parts& p, size_t entries, uint64_t run_count) {
  const size_t n = p.n;
  const bool runs = p.opt.storage == FFStorage::runs;
  p.row_start.resize(n + 1);
  in.read(p.row_start.data(), 8 * (n + 1));
  if (runs) {
    p.run_start.resize(n + 1);
    in.read(p.run_start.data(), 8 * (n + 1));
    p.run.resize(run_count);
    in.read(p.run.data(), sizeof(FFRun) * run_count);
  } else if (p.opt.storage == FFStorage::csr) {
    p.col.resize(entries);
    in.read(p.col.data(), 4 * entries);
  } else {
    p.step.resize(entries);
    in.read(p.step.data(), 2 * entries);
  }
  const size_t pad = runs ? kRunValuePad : 0;  // zeros past the last value (ff_matrix.hpp)
  if (p.opt.values == FFValues::float32) {
    p.f32.assign(entries + pad, 0.0f);
    in.read(p.f32.data(), 4 * entries);
  } else {
    p.u16.assign(entries + pad, 0);
    in.read(p.u16.data(), 2 * entries);
  }
}

// The runs storage's columns of row i's entries, in order (counting its runs of length 0 into empty_runs).
std::vector<int64_t> run_columns(const FormFactorMatrix::Parts& p, size_t i, size_t& empty_runs,
                                 const Corrupted& corrupted) {
  const int64_t k0 = p.row_start[i], k1 = p.row_start[i + 1];
  const int64_t r0 = p.run_start[i], r1 = p.run_start[i + 1];
  if (r1 < r0) throw corrupted("row " + std::to_string(i) + "'s runs end before they start");
  std::vector<int64_t> cols;
  int64_t end = 0;
  for (int64_t r = r0; r < r1; ++r) {
    const FFRun run = p.run[size_t(r)];
    empty_runs += run.length == 0;
    end += run.step;
    for (size_t q = 0; q < run.length; ++q) cols.push_back(end++);
  }
  if (int64_t(cols.size()) != k1 - k0)
    throw corrupted("row " + std::to_string(i) + ": runs of " + std::to_string(cols.size()) + " entries for " +
                    std::to_string(k1 - k0) + " values");
  return cols;
}

// Row i's entries: columns increasing below n (csr's, compressed's steps summed, or the runs' columns), values
// form factors (in [0, 1], 0 on the diagonal, as dense files' are); counts the values 0 into zeros.
void check_row(const FormFactorMatrix::Parts& p, size_t i, const std::vector<int64_t>& cols, size_t& zeros,
               const std::string& file, const Corrupted& corrupted) {
  const int64_t k0 = p.row_start[i], k1 = p.row_start[i + 1], n = int64_t(p.n);
  const bool runs = p.opt.storage == FFStorage::runs;
  int64_t prev = -1;
  for (int64_t k = k0; k < k1; ++k) {
    const int64_t j = runs                               ? cols[size_t(k - k0)]
                      : p.opt.storage == FFStorage::csr ? int64_t(p.col[size_t(k)])
                                                        : prev + p.step[size_t(k)];
    if (j <= prev || j >= n)
      throw corrupted("row " + std::to_string(i) + ": column " + std::to_string(j) + " after " +
                      std::to_string(prev) + " (columns increase from 0 to " + std::to_string(n - 1) + ")");
    prev = j;
    const size_t e = size_t(k);
    const double v = p.scale * (p.opt.values == FFValues::float32   ? double(p.f32[e])
                                : p.opt.values == FFValues::float16 ? double(half_to_float(p.u16[e]))
                                                                    : double(bfloat16_to_float(p.u16[e])));
    zeros += v == 0;
    if ((v < 0 || v > 1 || (size_t(j) == i && v != 0)) && !std::isnan(v))
      throw hpcgi::UsageError(file + ": F[" + std::to_string(i) + "][" + std::to_string(j) + "] = " +
                              std::to_string(v) +
                              (size_t(j) == i ? ": a patch's form factor to itself must be 0"
                                              : ": a form factor lies in [0, 1]"));
  }
}

// The structure (rows in order, columns increasing below n) and the values, against the payload's counts c.
void check_entries(const FormFactorMatrix::Parts& p, const Counts& c, uint64_t run_count, const std::string& file,
                   const Corrupted& corrupted) {
  const size_t n = p.n, entries = c.entries;
  const bool runs = p.opt.storage == FFStorage::runs;
  if (p.row_start[0] != 0 || p.row_start[n] != int64_t(entries))
    throw corrupted("row starts do not span the entries");
  if (runs && (p.run_start[0] != 0 || p.run_start[n] != int64_t(run_count)))
    throw corrupted("run starts do not span the runs");
  size_t zeros = 0, empty_runs = 0;
  for (size_t i = 0; i < n; ++i) {
    if (p.row_start[i + 1] < p.row_start[i]) throw corrupted("row " + std::to_string(i) + " ends before it starts");
    const std::vector<int64_t> cols = runs ? run_columns(p, i, empty_runs, corrupted) : std::vector<int64_t>();
    check_row(p, i, cols, zeros, file, corrupted);
  }
  if (runs && (empty_runs != c.bridges || zeros < c.entries - c.kept))
    throw corrupted(std::to_string(empty_runs) + " runs of length 0 and " + std::to_string(zeros) +
                    " values 0 against the header's " + std::to_string(c.bridges) + " bridges and " +
                    std::to_string(c.entries - c.kept) + " merged zeros");
  if (!runs && zeros < c.bridges)
    throw corrupted(std::to_string(zeros) + " entries of value 0, fewer than the header's " +
                    std::to_string(c.bridges) + " bridges");
}

}  // namespace

double sparse_payload_bytes(FFStorage storage, FFValues values, size_t n, size_t entries, size_t runs) {
  const double run_part = storage == FFStorage::runs ? 8.0 + 8.0 * double(n + 1) + double(sizeof(FFRun)) * double(runs) : 0;
  return double(sizeof(Counts)) + 8.0 * double(n + 1) + run_part +
         double(entries) * double(index_bytes(storage) + value_bytes(values));
}

void save_form_factor_matrix(const std::string& path, const Mesh& mesh, const HemicubeParams& params,
                             const FormFactorMatrix& m) {
  const FFMatrixView v = m.view();
  if (v.storage == FFStorage::dense) throw std::invalid_argument("save_form_factor_matrix: a sparse matrix only");
  if (v.n != mesh.size()) throw std::invalid_argument("save_form_factor_matrix: a matrix of another mesh");
  const size_t n = v.n, entries = size_t(v.row_start[n]);
  const Counts c{entries, m.kept(), m.bridges(), v.scale};
  const bool runs = v.storage == FFStorage::runs;
  const uint64_t run_count = runs ? uint64_t(v.run_start[n]) : 0;
  const void* index = v.storage == FFStorage::csr ? static_cast<const void*>(v.col) : v.step;
  const std::pair<const void*, size_t> pieces[] = {{&c, sizeof c},
                                                   {&run_count, runs ? 8 : 0},
                                                   {v.row_start, 8 * (n + 1)},
                                                   {v.run_start, runs ? 8 * (n + 1) : 0},
                                                   {v.run, sizeof(FFRun) * run_count},
                                                   {index, entries * index_bytes(v.storage)},
                                                   {v.data, entries * value_bytes(v.values)}};
  Fnv64 sum;
  uint64_t payload = 0;
  for (const auto& [p, bytes] : pieces) {
    sum.update(p, bytes);
    payload += bytes;
  }
  const uint64_t checksum = sum.finish();
  const auto header = sparse_form_factor_header(mesh, params, to_string(v.storage), to_string(v.values), payload);
  hpcgi::files::AtomicFile out(path);
  std::FILE* f = out.stream();
  bool ok = std::fwrite(header.data(), header.size(), 1, f) == 1;
  for (const auto& [p, bytes] : pieces) ok = ok && (bytes == 0 || std::fwrite(p, 1, bytes, f) == bytes);
  if (!ok || std::fwrite(&checksum, sizeof checksum, 1, f) != 1) out.fail(std::strerror(errno));
  out.commit();
}

FormFactorMatrix load_form_factor_matrix(const std::string& path, const Mesh& expected, HemicubeParams* params) {
  const FormFactorFileInfo info = check_any_form_factor_file(path, expected);
  if (params) *params = info.params;
  return load_form_factor_matrix(path, info);
}

FormFactorMatrix load_form_factor_matrix(const std::string& path, const FormFactorFileInfo& info) {
  const std::string file = "form-factor file '" + hpcgi::one_line(path) + "'";
  if (info.version == 1)
    throw hpcgi::UsageError(file + " holds dense float32 form factors (version 1), not a sparse matrix");
  FormFactorMatrix::Parts p;
  p.n = info.n;
  p.opt.storage = parse_ff_storage(info.storage);
  p.opt.values = parse_ff_values(info.precision);
  p.opt.threshold = info.params.threshold;
  const Corrupted corrupted = [&](const std::string& why) {
    return hpcgi::UsageError("corrupted " + file + ": " + why);
  };
  PayloadReader in(path, file);
  uint64_t run_count = 0;
  const Counts c = read_counts(in, info, p, run_count, corrupted);
  p.kept = c.kept;
  p.bridges = c.bridges;
  p.scale = c.scale;
  read_arrays(in, p, c.entries, run_count);
  if (!in.checksum_agrees()) throw corrupted("checksum mismatch");
  check_entries(p, c, run_count, file, corrupted);
  return FormFactorMatrix(std::move(p));
}

}  // namespace radiosity
