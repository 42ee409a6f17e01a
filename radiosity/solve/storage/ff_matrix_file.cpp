#include "radiosity/solve/storage/ff_matrix_file.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <stdexcept>

#include "common/errors.hpp"
#include "common/files.hpp"
#include "common/one_line.hpp"
#include "radiosity/formfactor/ff_file.hpp"
#include "radiosity/solve/storage/half.hpp"

namespace radiosity {
namespace {

struct Counts {
  uint64_t entries, kept, bridges;
  double scale;
};
static_assert(sizeof(Counts) == 32, "the payload's counts are part of the file format");

size_t index_bytes(FFStorage s) { return s == FFStorage::csr ? sizeof(int32_t) : sizeof(uint16_t); }

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};

}  // namespace

double sparse_payload_bytes(FFStorage storage, FFValues values, size_t n, size_t entries) {
  return double(sizeof(Counts)) + 8.0 * double(n + 1) + double(entries) * double(index_bytes(storage) + value_bytes(values));
}

void save_form_factor_matrix(const std::string& path, const Mesh& mesh, const HemicubeParams& params,
                             const FormFactorMatrix& m) {
  const FFMatrixView v = m.view();
  if (v.storage == FFStorage::dense) throw std::invalid_argument("save_form_factor_matrix: a sparse matrix only");
  if (v.n != mesh.size()) throw std::invalid_argument("save_form_factor_matrix: a matrix of another mesh");
  const size_t n = v.n, entries = size_t(v.row_start[n]);
  const Counts c{entries, m.kept(), m.bridges(), v.scale};
  const void* index = v.storage == FFStorage::csr ? static_cast<const void*>(v.col) : v.step;
  const std::pair<const void*, size_t> pieces[] = {{&c, sizeof c},
                                                   {v.row_start, 8 * (n + 1)},
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
  const std::string file = "form-factor file '" + hpcgi::one_line(path) + "'";
  const FormFactorFileInfo info = check_any_form_factor_file(path, expected);
  if (info.version == 1)
    throw hpcgi::UsageError(file + " holds dense float32 form factors (version 1), not a sparse matrix");
  if (params) *params = info.params;
  FormFactorMatrix::Parts p;
  p.n = info.n;
  p.opt.storage = parse_ff_storage(info.storage);
  p.opt.values = parse_ff_values(info.precision);
  p.opt.threshold = info.params.threshold;
  const size_t n = p.n;
  auto corrupted = [&](const std::string& why) { return hpcgi::UsageError("corrupted " + file + ": " + why); };

  std::unique_ptr<std::FILE, FileCloser> f(std::fopen(path.c_str(), "rb"));
  if (!f || std::fseek(f.get(), long(kFormFactorHeaderBytes), SEEK_SET) != 0)
    throw hpcgi::UsageError("cannot read " + file + ": " + std::strerror(errno));
  Fnv64 sum;
  auto read = [&](void* dst, size_t bytes) {
    if (bytes > 0 && std::fread(dst, 1, bytes, f.get()) != bytes)
      throw hpcgi::UsageError("cannot read " + file + ": " + std::strerror(errno));
    sum.update(dst, bytes);
  };
  Counts c{};
  if (info.payload_bytes < sizeof c) throw corrupted("a payload of " + std::to_string(info.payload_bytes) + " bytes");
  read(&c, sizeof c);
  const double want = sparse_payload_bytes(p.opt.storage, p.opt.values, n, c.entries);
  if (c.entries != c.kept + c.bridges || double(info.payload_bytes) != want)
    throw corrupted(std::to_string(c.entries) + " entries (" + std::to_string(c.kept) + " kept, " +
                    std::to_string(c.bridges) + " bridges) in a payload of " + std::to_string(info.payload_bytes) +
                    " bytes");
  if (!(c.scale > 0 && std::isfinite(c.scale)) || (p.opt.values != FFValues::float16 && c.scale != 1))
    throw corrupted("scale " + std::to_string(c.scale));
  p.kept = c.kept;
  p.bridges = c.bridges;
  p.scale = c.scale;
  const size_t entries = c.entries;
  p.row_start.resize(n + 1);
  read(p.row_start.data(), 8 * (n + 1));
  if (p.opt.storage == FFStorage::csr) {
    p.col.resize(entries);
    read(p.col.data(), 4 * entries);
  } else {
    p.step.resize(entries);
    read(p.step.data(), 2 * entries);
  }
  if (p.opt.values == FFValues::float32) {
    p.f32.resize(entries);
    read(p.f32.data(), 4 * entries);
  } else {
    p.u16.resize(entries);
    read(p.u16.data(), 2 * entries);
  }
  uint64_t stored = 0;
  if (std::fread(&stored, sizeof stored, 1, f.get()) != 1)
    throw hpcgi::UsageError("cannot read " + file + ": " + std::strerror(errno));
  if (stored != sum.finish()) throw corrupted("checksum mismatch");

  // The structure: rows in order, columns increasing below n; the values: form factors (as dense files' are).
  if (p.row_start[0] != 0 || p.row_start[n] != int64_t(entries)) throw corrupted("row starts do not span the entries");
  size_t zeros = 0;
  for (size_t i = 0; i < n; ++i) {
    const int64_t k0 = p.row_start[i], k1 = p.row_start[i + 1];
    if (k1 < k0) throw corrupted("row " + std::to_string(i) + " ends before it starts");
    int64_t prev = -1;
    for (int64_t k = k0; k < k1; ++k) {
      const int64_t j = p.opt.storage == FFStorage::csr ? int64_t(p.col[size_t(k)]) : prev + p.step[size_t(k)];
      if (j <= prev || j >= int64_t(n))
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
  if (zeros < c.bridges)
    throw corrupted(std::to_string(zeros) + " entries of value 0, fewer than the header's " +
                    std::to_string(c.bridges) + " bridges");
  return FormFactorMatrix(std::move(p));
}

}  // namespace radiosity
