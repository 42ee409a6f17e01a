// The form-factor file written and read by MPI ranks, each only its own block of rows, with MPI-IO: the one file
// of format.hpp, format unchanged (version 1). Rank 0 writes the header, every rank its rows at their offset
// (72 + 4·n·first row), and the checksum (FNV-1a over 64-bit words, a sequential hash) is computed as a chain:
// rank r receives the running hash from rank r - 1, with the bytes of a word its rows left unfinished (4n-byte rows
// end inside a word when n is odd), hashes its own bytes and hands on; the last rank writes or checks the result.
// So the bytes are exactly those of save_form_factors, whatever the number of ranks: files written by P ranks are
// read by the serial program and by any other number of ranks, and the serial program's files by any P.
#pragma once
#include <string>

#include "radiosity/dist/split.hpp"
#include "radiosity/formfactor/file/format.hpp"
#include "radiosity/formfactor/form_factors.hpp"
#include "radiosity/mesh.hpp"

namespace radiosity::dist {

// Where the time of a collective read or write went, on this rank.
struct FileStats {
  double io_s = 0;        // MPI-IO reads or writes of the rank's rows
  double checksum_s = 0;  // hashing the rank's bytes
  double chain_s = 0;     // waiting for the previous rank's hash (the chain is sequential)
};

// Collective. Every rank passes its block of rows (in rank order the blocks cover 0..n). Writes a unique temporary
// file beside path (common/files.hpp) and, once every rank has written, rank 0 renames it to path: path is never half-written. If any rank fails, every rank
// throws the same hpcgi::Agreed error and the temporary file is removed.
FileStats save_form_factor_rows(const std::string& path, const Mesh& mesh, const FormFactors& rows);

// Collective. This rank's block of rows of the file for mesh `expected` (in rank order the blocks cover 0..n), with
// every check of load_form_factors: the header and size on every rank, the checksum over all ranks' bytes by the
// chain. A refusal is the same hpcgi::Agreed<UsageError> on every rank.
FormFactors load_form_factor_rows(const std::string& path, const Mesh& expected, RowBlock block,
                                  FileStats* stats = nullptr);
// The same on a file whose header every rank has read and checked once already (info: check_form_factor_file's).
FormFactors load_form_factor_rows(const std::string& path, const FormFactorFileInfo& info, RowBlock block,
                                  FileStats* stats = nullptr);

}  // namespace radiosity::dist
