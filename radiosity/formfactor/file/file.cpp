#include "radiosity/formfactor/file/file.hpp"

#include <fstream>
#include <stdexcept>
#include <utility>

#include "common/errors.hpp"

#include "radiosity/formfactor/file/sparse.hpp"

namespace radiosity {
namespace {

// A dense file's values (every row, or an MPI rank's block) as the one matrix: dense float32, moved, not copied.
FormFactorMatrix dense_matrix(FormFactors&& ff) {
  FormFactorMatrix::Parts parts;
  parts.n = ff.n;
  parts.row_begin = ff.first_row();
  parts.row_end = ff.last_row();
  parts.f32 = std::move(ff.values);
  return FormFactorMatrix(std::move(parts));
}

}  // namespace

FormFactorFile FormFactorFile::open(const std::string& path) {
  FormFactorFile f;
  f.header_ = open_form_factor_file(path);
  return f;
}

FormFactorFile FormFactorFile::checked(const Mesh& m) const {
  FormFactorFile f = *this;
  f.info_ = check_form_factor_header(header_, m);
  f.checked_ = true;
  return f;
}

const FormFactorFile& FormFactorFile::require_dense() const {
  refuse_sparse(info(), path());
  return *this;
}

FormFactorMatrix FormFactorFile::read(const FormFactorRead& how) const {
  if (!checked_) throw std::logic_error("FormFactorFile::read: the file was not checked against its mesh");
  if (how.rank_rows) {
    if (sparse()) throw std::logic_error("FormFactorFile::read: an MPI rank's rows are read from a dense file");
#ifdef HAVE_MPI
    return dense_matrix(dist::load_form_factor_rows(path(), info_, how.rows, how.stats));
#else
    throw std::logic_error("FormFactorFile::read: an MPI rank's rows in a build without MPI");
#endif
  }
  if (sparse()) return load_form_factor_matrix(path(), info_);
  return dense_matrix(load_form_factors(path(), info_));
}

uint64_t FormFactorFile::stored_checksum() const {
  if (!checked_) throw std::logic_error("FormFactorFile::stored_checksum: the file was not checked against its mesh");
  std::ifstream f(path(), std::ios::binary);
  uint64_t sum = 0;
  f.seekg(std::streamoff(kFormFactorHeaderBytes + info_.payload_bytes));  // both versions end in the checksum
  if (!f.read(reinterpret_cast<char*>(&sum), sizeof sum))
    throw hpcgi::UsageError(path() + ": cannot read the form-factor file's checksum");
  return sum;
}

}  // namespace radiosity
