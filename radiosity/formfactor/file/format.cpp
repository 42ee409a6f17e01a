#include "radiosity/formfactor/file/format.hpp"
#include "common/files.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <stdexcept>

#include "common/errors.hpp"
#include "common/one_line.hpp"

namespace radiosity {
namespace {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "the form-factor file is written as the machine's memory");

constexpr char kMagic[8] = {'H', 'P', 'C', 'G', 'I', 'F', 'F', '\0'};
constexpr uint32_t kVersion = 1;        // dense float32
constexpr uint32_t kSparseVersion = 2;  // csr, compressed or runs (format.hpp)

// A header name field holds 7 characters: version 2 writes "compressed" as "csrd16" and "bfloat16" as "bf16".
struct Code {
  const char* name;
  const char* code;
};
constexpr Code kCodes[] = {{"compressed", "csrd16"}, {"bfloat16", "bf16"}};
std::string code_of(const std::string& name) {
  for (const Code& c : kCodes)
    if (name == c.name) return c.code;
  return name;
}
std::string name_of_code(const std::string& code) {
  for (const Code& c : kCodes)
    if (code == c.code) return c.name;
  return code;
}

struct Header {
  char magic[8];
  uint32_t version;
  uint32_t resolution;
  uint64_t n;
  char storage[8];
  char precision[8];
  uint64_t mesh_hash;
  char weights[8];
  double threshold;
  uint64_t values_bytes;
};
static_assert(sizeof(Header) == 72, "the header layout is part of the file format");

// FNV-1a over 64-bit words (8 times fewer multiplications than byte-wise FNV-1a on a file of gigabytes), the
// trailing bytes one by one.
uint64_t checksum(const void* data, size_t bytes) {
  Fnv64 h;
  h.update(data, bytes);
  return h.finish();
}

void set_name(char (&field)[8], const std::string& s) {
  std::memset(field, 0, sizeof field);
  std::memcpy(field, s.data(), std::min(s.size(), sizeof field - 1));
}

// The name in a header field, fit to quote in a message (a corrupted field may hold any byte).
std::string name_of(const char (&field)[8]) { return hpcgi::one_line({field, strnlen(field, sizeof field)}); }

std::string hex(uint64_t v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "0x%016llx", static_cast<unsigned long long>(v));
  return buf;
}

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

}  // namespace

void Fnv64::update(const void* data, size_t bytes) {
  const unsigned char* p = static_cast<const unsigned char*>(data);
  constexpr uint64_t kPrime = 1099511628211ull;
  while (npending > 0 && npending < 8 && bytes > 0) {  // complete the word a previous piece began
    pending[npending++] = *p++;
    --bytes;
  }
  if (npending == 8) {
    uint64_t w;
    std::memcpy(&w, pending, 8);
    hash = (hash ^ w) * kPrime;
    npending = 0;
  }
  size_t i = 0;
  for (; i + 8 <= bytes; i += 8) {
    uint64_t w;
    std::memcpy(&w, p + i, 8);
    hash = (hash ^ w) * kPrime;
  }
  for (; i < bytes; ++i) pending[npending++] = p[i];
}

uint64_t Fnv64::finish() const {
  uint64_t h = hash;
  for (uint32_t k = 0; k < npending; ++k) h = (h ^ pending[k]) * 1099511628211ull;
  return h;
}

std::array<char, kFormFactorHeaderBytes> form_factor_header(const Mesh& mesh, const HemicubeParams& params) {
  Header h{};
  std::memcpy(h.magic, kMagic, sizeof kMagic);
  h.version = kVersion;
  h.resolution = static_cast<uint32_t>(params.resolution);
  h.n = mesh.size();
  set_name(h.storage, "dense");
  set_name(h.precision, "float32");
  h.mesh_hash = mesh_hash(mesh);
  set_name(h.weights, to_string(params.weights));
  h.threshold = params.threshold;
  h.values_bytes = uint64_t(h.n) * h.n * sizeof(float);
  std::array<char, kFormFactorHeaderBytes> bytes;
  std::memcpy(bytes.data(), &h, sizeof h);
  return bytes;
}

std::array<char, kFormFactorHeaderBytes> sparse_form_factor_header(const Mesh& mesh, const HemicubeParams& params,
                                                                   const std::string& storage,
                                                                   const std::string& precision,
                                                                   uint64_t payload_bytes) {
  auto bytes = form_factor_header(mesh, params);
  Header h;
  std::memcpy(&h, bytes.data(), sizeof h);
  h.version = kSparseVersion;
  set_name(h.storage, code_of(storage));
  set_name(h.precision, code_of(precision));
  h.values_bytes = payload_bytes;
  std::memcpy(bytes.data(), &h, sizeof h);
  return bytes;
}

void save_form_factors(const std::string& path, const Mesh& mesh, const FormFactors& ff) {
  if (ff.n != mesh.size() || ff.values.size() != ff.n * ff.n)
    throw std::invalid_argument("save_form_factors: a matrix for " + std::to_string(ff.n) +
                                " patches does not belong to a mesh of " + std::to_string(mesh.size()));
  const auto header = form_factor_header(mesh, ff.params);
  const size_t values_bytes = ff.values.size() * sizeof(float);
  const uint64_t sum = checksum(ff.values.data(), values_bytes);

  hpcgi::files::AtomicFile out(path);  // a unique temporary file beside it, renamed over it when whole
  std::FILE* f = out.stream();
  if (std::fwrite(header.data(), header.size(), 1, f) != 1 || std::fwrite(ff.values.data(), 1, values_bytes, f) != values_bytes ||
      std::fwrite(&sum, sizeof sum, 1, f) != 1)
    out.fail(std::strerror(errno));
  out.commit();
}

namespace {

// The test-only hook that counts header reads (format.hpp): one line "pid path" appended to the file it names.
void count_header_read(const std::string& path) {
  const char* log = std::getenv(kHeaderReadLogEnv);
  if (!log || !*log) return;
  if (std::FILE* f = std::fopen(log, "a")) {
    std::fprintf(f, "%ld %s\n", long(getpid()), path.c_str());
    std::fclose(f);
  }
}

// Reads the header and the size of an open file and checks what the header says of itself (magic, version,
// storage, precision); leaves the file positioned after the header.
FormFactorFileHeader read_header(std::FILE* f, const std::string& path) {
  count_header_read(path);
  const std::string file = "form-factor file '" + path + "'";
  if (std::fseek(f, 0, SEEK_END) != 0) throw hpcgi::UsageError("cannot read " + file);
  const long size_or_error = std::ftell(f);
  if (size_or_error < 0) throw hpcgi::UsageError("cannot read " + file);
  FormFactorFileHeader out;
  out.path = path;
  out.size = static_cast<uint64_t>(size_or_error);
  std::rewind(f);

  Header h{};
  const size_t got = std::fread(&h, 1, sizeof h, f);
  if (got < sizeof h.magic || std::memcmp(h.magic, kMagic, sizeof kMagic) != 0)
    throw hpcgi::UsageError("'" + path + "' is not a form-factor file (bad magic)");
  if (got < sizeof h)
    throw hpcgi::UsageError("truncated " + file + ": expected at least " + std::to_string(sizeof h) +
                            " bytes of header, found " + std::to_string(out.size));
  if (h.version != kVersion && h.version != kSparseVersion)
    throw hpcgi::UsageError("unsupported " + file + " version " + std::to_string(h.version) +
                            " (this program reads versions " + std::to_string(kVersion) + " and " +
                            std::to_string(kSparseVersion) + ")");
  const bool sparse = h.version == kSparseVersion;
  const std::string storage = sparse ? name_of_code(name_of(h.storage)) : name_of(h.storage),
                    precision = sparse ? name_of_code(name_of(h.precision)) : name_of(h.precision);
  if (!sparse && (storage != "dense" || precision != "float32"))
    throw hpcgi::UsageError("unsupported " + file + ": storage '" + storage + "', precision '" + precision +
                            "' (version 1 holds dense float32)");
  if (sparse && ((storage != "csr" && storage != "compressed" && storage != "runs") ||
                 (precision != "float32" && precision != "float16" && precision != "bfloat16")))
    throw hpcgi::UsageError("unsupported " + file + ": storage '" + storage + "', precision '" + precision +
                            "' (version 2 holds csr, compressed or runs, float32, float16 or bfloat16)");
  std::memcpy(out.bytes.data(), &h, sizeof h);
  out.info.n = h.n;
  out.info.version = h.version;
  out.info.storage = storage;
  out.info.precision = precision;
  out.info.payload_bytes = h.values_bytes;
  return out;
}

}  // namespace

FormFactorFileHeader open_form_factor_file(const std::string& path) {
  hpcgi::files::require_input(path, "form-factor file");  // a FIFO would block, a folder is no file
  File f(std::fopen(path.c_str(), "rb"));
  if (!f) throw hpcgi::UsageError("cannot open form-factor file '" + path + "': " + std::strerror(errno));
  return read_header(f.get(), path);
}

FormFactorFileInfo check_form_factor_header(const FormFactorFileHeader& header, const Mesh& expected) {
  const std::string file = "form-factor file '" + header.path + "'";
  Header h;
  std::memcpy(&h, header.bytes.data(), sizeof h);
  const bool sparse = h.version == kSparseVersion;
  const uint64_t hash = mesh_hash(expected);
  if (h.n != expected.size() || h.mesh_hash != hash)
    throw hpcgi::UsageError(file + " belongs to another mesh: the file has " + std::to_string(h.n) +
                            " patches, mesh hash " + hex(h.mesh_hash) + "; the scene has " +
                            std::to_string(expected.size()) + " patches, mesh hash " + hex(hash) +
                            " (recompute the form factors)");
  if (!sparse && h.values_bytes != h.n * h.n * sizeof(float))
    throw hpcgi::UsageError("corrupted " + file + ": " + std::to_string(h.values_bytes) + " bytes of values for " +
                            std::to_string(h.n) + " patches");
  const uint64_t want = sizeof h + h.values_bytes + sizeof(uint64_t);
  if (header.size != want)
    throw hpcgi::UsageError((header.size < want ? "truncated " : "oversized ") + file + ": expected " +
                            std::to_string(want) + " bytes, found " + std::to_string(header.size));
  FormFactorFileInfo info = header.info;
  try {
    info.params.resolution = static_cast<int>(h.resolution);
    info.params.weights = parse_hemicube_weights(name_of(h.weights));
    info.params.threshold = h.threshold;
    validate(info.params);
  } catch (const hpcgi::UsageError& e) {
    throw hpcgi::UsageError("corrupted " + file + ": " + e.what());
  }
  return info;
}

namespace {
// Reads and checks the header and the size of an open file against the mesh; leaves the file positioned after the
// header.
FormFactorFileInfo check_header(std::FILE* f, const std::string& path, const Mesh& expected) {
  return check_form_factor_header(read_header(f, path), expected);
}
}  // namespace

FormFactorFileInfo check_any_form_factor_file(const std::string& path, const Mesh& expected) {
  return check_form_factor_header(open_form_factor_file(path), expected);
}

void refuse_sparse(const FormFactorFileInfo& info, const std::string& path) {
  if (info.version != kVersion)
    throw hpcgi::UsageError("form-factor file '" + hpcgi::one_line(path) + "' holds " + info.storage + " " +
                            info.precision + " form factors (version 2); this reads dense float32 (version 1): write "
                            "the file with formfactors --storage dense");
}

FormFactorFileInfo check_form_factor_file(const std::string& path, const Mesh& expected) {
  const FormFactorFileInfo info = check_any_form_factor_file(path, expected);
  refuse_sparse(info, path);
  return info;
}

namespace {
// The dense values of an open file f positioned after its header (info: that header, checked), checksum and values
// checked.
FormFactors read_dense_values(std::FILE* f, const std::string& path, const FormFactorFileInfo& info) {
  const std::string file = "form-factor file '" + path + "'";
  refuse_sparse(info, path);
  FormFactors ff;
  ff.n = info.n;
  ff.params = info.params;
  ff.row_end = ff.n;
  const size_t values_bytes = ff.n * ff.n * sizeof(float);
  ff.values.resize(ff.n * ff.n);
  uint64_t sum = 0;
  if (std::fread(ff.values.data(), 1, values_bytes, f) != values_bytes || std::fread(&sum, sizeof sum, 1, f) != 1)
    throw hpcgi::UsageError("cannot read " + file + ": " + std::strerror(errno));
  if (sum != checksum(ff.values.data(), values_bytes))
    throw hpcgi::UsageError("corrupted " + file + ": checksum mismatch");
  check_form_factor_values(ff.values.data(), ff.n, ff.n, 0, path);
  return ff;
}
}  // namespace

FormFactors load_form_factors(const std::string& path, const Mesh& expected) {
  hpcgi::files::require_input(path, "form-factor file");
  File f(std::fopen(path.c_str(), "rb"));
  if (!f) throw hpcgi::UsageError("cannot open form-factor file '" + path + "': " + std::strerror(errno));
  const FormFactorFileInfo info = check_header(f.get(), path, expected);
  return read_dense_values(f.get(), path, info);
}

FormFactors load_form_factors(const std::string& path, const FormFactorFileInfo& info) {
  File f(std::fopen(path.c_str(), "rb"));
  if (!f || std::fseek(f.get(), long(kFormFactorHeaderBytes), SEEK_SET) != 0)
    throw hpcgi::UsageError("cannot open form-factor file '" + path + "': " + std::strerror(errno));
  return read_dense_values(f.get(), path, info);
}

void check_form_factor_values(const float* values, size_t rows, size_t n, size_t first_row, const std::string& path) {
  for (size_t r = 0; r < rows; ++r) {
    const float* row = values + r * n;
    const size_t i = first_row + r;
    for (size_t j = 0; j < n; ++j) {
      const float v = row[j];
      if ((v < 0 || v > 1 || (j == i && v != 0)) && !std::isnan(v))
        throw hpcgi::UsageError("form-factor file '" + hpcgi::one_line(path) + "': F[" + std::to_string(i) + "][" +
                                std::to_string(j) + "] = " + std::to_string(v) +
                                (j == i ? ": a patch's form factor to itself must be 0" : ": a form factor lies in [0, 1]"));
    }
  }
}

}  // namespace radiosity
