// The form-factor file: F computed once (the expensive part) and reused for any lighting or reflectivity of the same
// geometry (report §3.6). A file names the mesh it belongs to, so a stale or foreign file is refused, never used.
// Programs read it through file.hpp (FormFactorFile: open, checked, read), the one way in; this file holds the format,
// its checks and the dense reader and writer.
//
// Layout, little-endian, 72-byte header:
//   0  char[8]  magic "HPCGIFF\0"          40 uint64   mesh_hash(mesh)
//   8  uint32   format version (1)         48 char[8]  hemicube weights, "exact" or "rrv2007", NUL-padded
//   12 uint32   hemicube resolution R      56 float64  threshold
//   16 uint64   patch count n              64 uint64   bytes of values that follow (4·n²)
//   24 char[8]  storage "dense"
//   32 char[8]  value precision "float32"
// then n² float32 values, row-major (F[i*n + j]), then a uint64 checksum of those bytes (FNV-1a over 64-bit words).
// A file's size is therefore known from its header, and a truncated file is told from a corrupted one.
//
// Version 2 (issue 17) holds F sparse: the same header with version 2, storage "csr", "csrd16" (compressed) or "runs",
// precision "float32", "float16" or "bf16" (bfloat16) and at 64 the bytes of the payload that follows (radiosity/solve/storage/ff_matrix.hpp
// describes the storages; radiosity/formfactor/file/sparse.hpp writes and reads the payload); then the payload's
// checksum as above. Dense files stay version 1, byte for byte as before, and every reader of dense F (relight,
// web, backend mpi, the peers) refuses a version 2 file with one line.
//
// The file does not depend on how it was made: one process, or MPI ranks each writing their rows into it in parallel
// (radiosity/formfactor/file/mpi_rows.hpp) give the same bytes, and any number of ranks reads either.
#pragma once
#include <array>
#include <cstdint>
#include <string>

#include "radiosity/formfactor/form_factors.hpp"
#include "radiosity/mesh.hpp"

namespace radiosity {

inline constexpr uint64_t kFormFactorHeaderBytes = 72;

// The checksum: FNV-1a over 64-bit little-endian words, the last bytes (when the length is no multiple of 8) one by
// one. Fed in pieces of any size, a piece ending inside a word carrying its bytes to the next; the state is plain
// data, so that an MPI rank can hand it on to the next rank, which goes on where it stopped.
struct Fnv64 {
  uint64_t hash = 1469598103934665603ull;
  uint8_t pending[8] = {};  // bytes of a word not yet complete
  uint32_t npending = 0;
  void update(const void* data, size_t bytes);
  uint64_t finish() const;  // the checksum of everything fed so far
};

// What a form-factor file's header says, once checked against the mesh: enough to read any of its rows.
struct FormFactorFileInfo {
  size_t n = 0;
  HemicubeParams params;
  uint32_t version = 1;
  std::string storage = "dense", precision = "float32";  // version 2: the sparse storage and its values
  uint64_t payload_bytes = 0;                             // the bytes between the header and the checksum
  uint64_t row_offset(size_t i) const { return kFormFactorHeaderBytes + 4 * uint64_t(i) * n; }
  uint64_t checksum_offset() const { return row_offset(n); }
  uint64_t file_bytes() const { return checksum_offset() + 8; }
};

// A form-factor file opened and its header read once, checked for what it says of itself (magic, version, storage,
// precision), not yet against a mesh: what a program reads before it has the mesh (bin/radiosity solve's plan).
// info holds n, the version, storage, precision and payload bytes; its params once checked against the mesh.
struct FormFactorFileHeader {
  std::string path;
  std::array<char, kFormFactorHeaderBytes> bytes{};
  uint64_t size = 0;  // the file's bytes
  FormFactorFileInfo info;
};
FormFactorFileHeader open_form_factor_file(const std::string& path);
// The rest of the header's checks, against the mesh it must belong to (patch count and hash, then the size and the
// hemicube): the file's info, as check_any_form_factor_file gives it. The header is not read again.
FormFactorFileInfo check_form_factor_header(const FormFactorFileHeader& header, const Mesh& expected);

// The header of the file for this mesh and these hemicube parameters: what save_form_factors writes first.
std::array<char, kFormFactorHeaderBytes> form_factor_header(const Mesh& mesh, const HemicubeParams& params);

// Opens path and checks its header and size against `expected`, with every refusal of load_form_factors but the
// checksum (the values are not read). A version 2 (sparse) file is refused, saying what it holds.
FormFactorFileInfo check_form_factor_file(const std::string& path, const Mesh& expected);

// A version 2 (sparse) file refused with one line saying what it holds, by a reader of dense float32 F.
void refuse_sparse(const FormFactorFileInfo& info, const std::string& path);

// The same checks for a file of either version: what a reader of sparse F calls first.
FormFactorFileInfo check_any_form_factor_file(const std::string& path, const Mesh& expected);

// The header of a version 2 file: storage and precision names, payload_bytes of payload after it.
std::array<char, kFormFactorHeaderBytes> sparse_form_factor_header(const Mesh& mesh, const HemicubeParams& params,
                                                                   const std::string& storage,
                                                                   const std::string& precision,
                                                                   uint64_t payload_bytes);

// Writes a unique temporary file beside path, then renames it to path (common/files.hpp): path is never
// half-written. Throws std::runtime_error if
// the file cannot be written and std::invalid_argument if ff is not a matrix for this mesh.
void save_form_factors(const std::string& path, const Mesh& mesh, const FormFactors& ff);

// Reads a file written by save_form_factors for the mesh `expected`. Refuses with a UsageError naming the file and
// the reason: it cannot be opened; not a form-factor file (bad magic); an unsupported version, storage or
// precision; a file for another mesh (patch count or hash differ: both are given); a truncated file (expected and
// actual sizes in bytes); a checksum mismatch.
FormFactors load_form_factors(const std::string& path, const Mesh& expected);
// The same on a file whose header was read and checked once already (info: check_form_factor_file's or
// check_any_form_factor_file's): the values and the checksum, the header not parsed again.
FormFactors load_form_factors(const std::string& path, const FormFactorFileInfo& info);

// A test-only hook: when this environment variable names a file, every parse of a form-factor file's header
// appends one line "PID PATH" to it, so that a test can count the parses of one file per process.
inline constexpr const char* kHeaderReadLogEnv = "HPCGI_TEST_FF_HEADER_LOG";

// Form factors are fractions: a value outside [0, 1] (finite; NaN is left to the solvers' guards, which stop at
// step 1 and say so) or a self form factor F_ii other than 0 (a planar patch does not see itself) is refused with
// UsageError naming the file, the row and the column. values holds rows [first_row, first_row + rows) of n columns.
void check_form_factor_values(const float* values, size_t rows, size_t n, size_t first_row, const std::string& path);

// A row of F sums to at most 1 (what leaves a patch); the hemicube's rounding gives a little more. Row sums above
// this are reported by `formfactors` as a note (a coarse hemicube: R = 2 gives 1.13): the answer then gains energy.
inline constexpr double kRowSumNote = 1.01;

}  // namespace radiosity
