// The form-factor file's one way in. open() checks the input and reads the header once (checked for what it says of
// itself); checked() checks that header against the mesh the file must belong to; read() returns what is asked of it
// as the one FormFactorMatrix: every row dense, a sparse file as stored, or (collective, by MPI-IO, the checksum
// chained over the ranks) an MPI rank's block of a dense file's rows. Nothing else reads the file's values.
//
// The format and the writers: format.hpp (version 1, dense, and the header), sparse.hpp (version 2), mpi_rows.hpp
// (the ranks' rows of version 1).
#pragma once
#include <cstdint>
#include <string>

#include "radiosity/dist/split.hpp"
#include "radiosity/formfactor/file/format.hpp"
#include "radiosity/formfactor/file/mpi_rows.hpp"
#include "radiosity/mesh.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"

namespace radiosity {

// What read() is asked.
struct FormFactorRead {
  // rank_rows: the rows [rows.begin, rows.end), an MPI rank's block, read collectively by every rank, each its own
  // (a dense file only; backend mpi). Else (the default) every row, by this process alone.
  bool rank_rows = false;
  dist::RowBlock rows{0, 0};
  dist::FileStats* stats = nullptr;  // an MPI rank's read: where its time went
};

class FormFactorFile {
 public:
  // Throws hpcgi::UsageError naming the file: not a regular file, cannot be opened, not a form-factor file, an
  // unsupported version, storage or precision.
  static FormFactorFile open(const std::string& path);
  // This file checked against the mesh it must belong to (patch count and hash, size, hemicube): UsageError else.
  FormFactorFile checked(const Mesh& m) const;

  const std::string& path() const { return header_.path; }
  // The header's facts: n, version, storage, precision, payload bytes; the hemicube once checked().
  const FormFactorFileInfo& info() const { return checked_ ? info_ : header_.info; }
  bool sparse() const { return info().version != 1; }
  // A reader of dense float32 F (relight, web, the error reference) refuses a sparse file with one line.
  const FormFactorFile& require_dense() const;

  // The values as asked (checked() first: std::logic_error else), with every check of the file's readers (the
  // checksum, each value in [0, 1], F_ii = 0, a sparse file's structure).
  FormFactorMatrix read(const FormFactorRead& how = {}) const;
  // The checksum the file ends with, read alone (checked() first): the values' identity, for what is derived from
  // them (the light basis, relight/basis_file.hpp). Not verified here: read() does.
  uint64_t stored_checksum() const;

 private:
  FormFactorFileHeader header_;
  FormFactorFileInfo info_;
  bool checked_ = false;
};

}  // namespace radiosity
