#include "radiosity/formfactor/file/mpi_rows.hpp"

#include "common/files.hpp"

#include <mpi.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>

#include "common/comm.hpp"
#include "common/errors.hpp"
#include "common/timer.hpp"
#include "radiosity/formfactor/file/format.hpp"

namespace radiosity::dist {
namespace {

// MPI counts are ints: rows go in pieces of at most 1 GiB.
constexpr uint64_t kPiece = uint64_t(1) << 30;

std::string mpi_error(int code) {
  char text[MPI_MAX_ERROR_STRING];
  int len = 0;
  MPI_Error_string(code, text, &len);
  return std::string(text, size_t(len));
}

// Reads or writes `bytes` at `offset` in pieces; returns "" or what went wrong.
template <bool Write>
std::string transfer(MPI_File fh, uint64_t offset, char* data, uint64_t bytes) {
  for (uint64_t done = 0; done < bytes;) {
    const int count = int(std::min(kPiece, bytes - done));
    MPI_Status st;
    const int rc = Write ? MPI_File_write_at(fh, MPI_Offset(offset + done), data + done, count, MPI_BYTE, &st)
                         : MPI_File_read_at(fh, MPI_Offset(offset + done), data + done, count, MPI_BYTE, &st);
    if (rc != MPI_SUCCESS) return mpi_error(rc);
    int got = 0;
    MPI_Get_count(&st, MPI_BYTE, &got);
    if (got != count) return "short " + std::string(Write ? "write" : "read") + " (disk full?)";
    done += uint64_t(count);
  }
  return "";
}

// The checksum chain over the ranks' bytes in rank order: returns the finished hash on the last rank (0 on the
// others).
uint64_t chained_checksum(const void* data, size_t bytes, FileStats& st) {
  const int rank = hpcgi::comm::rank(), size = hpcgi::comm::size();
  Fnv64 h;
  hpcgi::Timer t;
  if (rank > 0) MPI_Recv(&h, sizeof h, MPI_BYTE, rank - 1, 7, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  st.chain_s = t.seconds();
  t.reset();
  h.update(data, bytes);
  st.checksum_s = t.seconds();
  if (rank + 1 < size) {
    MPI_Send(&h, sizeof h, MPI_BYTE, rank + 1, 7, MPI_COMM_WORLD);
    return 0;
  }
  return h.finish();
}

}  // namespace

FileStats save_form_factor_rows(const std::string& path, const Mesh& mesh, const FormFactors& rows) {
  const int rank = hpcgi::comm::rank(), size = hpcgi::comm::size();
  const size_t n = mesh.size();
  if (rows.n != n || rows.values.size() != rows.rows() * n)
    throw std::invalid_argument("save_form_factor_rows: a block of rows that does not belong to a mesh of " +
                                std::to_string(n));
  FileStats st;
  const std::string file = "form-factor file '" + path + "'";
  FormFactorFileInfo info;
  info.n = n;
  MPI_File fh = MPI_FILE_NULL;
  std::string tmp;
  int slot = -1;
  // Every failure goes through here: the ranks agree, close the file, and rank 0 removes the temporary file.
  auto settle = [&](const std::string& error) {
    try {
      hpcgi::comm::agree(error.empty() ? 0 : hpcgi::kExitRuntime, error);
    } catch (...) {
      if (fh != MPI_FILE_NULL) MPI_File_close(&fh);
      if (rank == 0 && !tmp.empty()) std::remove(tmp.c_str());
      if (rank == 0) hpcgi::files::release_temp(slot);
      throw;
    }
  };
  // A unique temporary file beside the target (common/files.hpp), made by rank 0 and opened by name by all ranks.
  std::string error0;
  if (rank == 0) {
    try {
      tmp = hpcgi::files::make_temp_beside(path, slot);
    } catch (const std::exception& e) {
      error0 = e.what();
    }
  }
  settle(error0);
  unsigned long len = tmp.size();
  MPI_Bcast(&len, 1, MPI_UNSIGNED_LONG, 0, MPI_COMM_WORLD);
  tmp.resize(len);
  MPI_Bcast(tmp.data(), static_cast<int>(len), MPI_CHAR, 0, MPI_COMM_WORLD);

  int rc = MPI_File_open(MPI_COMM_WORLD, tmp.c_str(), MPI_MODE_CREATE | MPI_MODE_WRONLY, MPI_INFO_NULL, &fh);
  if (rc != MPI_SUCCESS) fh = MPI_FILE_NULL;
  settle(rc == MPI_SUCCESS ? "" : "cannot create " + file + " (temporary " + tmp + "): " + mpi_error(rc));
  // Sized to the file (collective).
  rc = MPI_File_set_size(fh, MPI_Offset(info.file_bytes()));
  settle(rc == MPI_SUCCESS ? "" : "cannot size " + file + ": " + mpi_error(rc));

  hpcgi::Timer t;
  std::string error;
  if (rank == 0) {
    auto header = form_factor_header(mesh, rows.params);
    error = transfer<true>(fh, 0, header.data(), header.size());
  }
  if (error.empty())
    error = transfer<true>(fh, info.row_offset(rows.first_row()),
                           reinterpret_cast<char*>(const_cast<float*>(rows.values.data())),
                           uint64_t(rows.values.size()) * sizeof(float));
  st.io_s = t.seconds();
  settle(error.empty() ? "" : "cannot write " + file + " on rank " + std::to_string(rank) + ": " + error);

  uint64_t sum = chained_checksum(rows.values.data(), rows.values.size() * sizeof(float), st);
  if (rank == size - 1) error = transfer<true>(fh, info.checksum_offset(), reinterpret_cast<char*>(&sum), sizeof sum);
  settle(error.empty() ? "" : "cannot write " + file + ": " + error);

  rc = MPI_File_sync(fh);
  settle(rc == MPI_SUCCESS ? "" : "cannot sync " + file + ": " + mpi_error(rc));
  rc = MPI_File_close(&fh);
  fh = MPI_FILE_NULL;
  settle(rc == MPI_SUCCESS ? "" : "cannot write " + file + ": " + mpi_error(rc));
  // Every rank's bytes are in (the close is collective); rank 0 makes the file whole under its name.
  if (rank == 0 && std::rename(tmp.c_str(), hpcgi::files::resolve_target(path).c_str()) != 0)
    error = "cannot rename the finished " + file + ": " + std::strerror(errno);
  settle(error);
  if (rank == 0) hpcgi::files::release_temp(slot);
  return st;
}

FormFactors load_form_factor_rows(const std::string& path, const Mesh& expected, RowBlock block, FileStats* stats) {
  const FormFactorFileInfo info = hpcgi::comm::agreed([&] { return check_form_factor_file(path, expected); });
  return load_form_factor_rows(path, info, block, stats);
}

FormFactors load_form_factor_rows(const std::string& path, const FormFactorFileInfo& info, RowBlock block,
                                  FileStats* stats) {
  const int rank = hpcgi::comm::rank(), size = hpcgi::comm::size();
  const std::string file = "form-factor file '" + path + "'";
  if (block.begin > block.end || block.end > info.n)
    throw std::invalid_argument("load_form_factor_rows: rows " + std::to_string(block.begin) + ".." +
                                std::to_string(block.end) + " of " + std::to_string(info.n));
  FileStats st;
  FormFactors rows;
  rows.n = info.n;
  rows.params = info.params;
  rows.row_begin = block.begin;
  rows.row_end = block.end;
  rows.values.resize(block.rows() * info.n);

  MPI_File fh = MPI_FILE_NULL;
  int rc = MPI_File_open(MPI_COMM_WORLD, path.c_str(), MPI_MODE_RDONLY, MPI_INFO_NULL, &fh);
  if (rc != MPI_SUCCESS) fh = MPI_FILE_NULL;
  hpcgi::comm::agreed([&] {
    if (rc != MPI_SUCCESS) throw hpcgi::UsageError("cannot open " + file + ": " + mpi_error(rc));
  });
  hpcgi::Timer t;
  std::string error = transfer<false>(fh, info.row_offset(block.begin), reinterpret_cast<char*>(rows.values.data()),
                                      uint64_t(rows.values.size()) * sizeof(float));
  uint64_t stored = 0;
  if (error.empty() && rank == size - 1)
    error = transfer<false>(fh, info.checksum_offset(), reinterpret_cast<char*>(&stored), sizeof stored);
  st.io_s = t.seconds();
  MPI_File_close(&fh);
  hpcgi::comm::agreed([&] {
    if (!error.empty())
      throw hpcgi::UsageError("cannot read " + file + " on rank " + std::to_string(rank) + ": " + error);
  });

  const uint64_t sum = chained_checksum(rows.values.data(), rows.values.size() * sizeof(float), st);
  int ok = rank == size - 1 ? int(sum == stored) : 0;
  MPI_Bcast(&ok, 1, MPI_INT, size - 1, MPI_COMM_WORLD);
  if (!ok) throw hpcgi::Agreed<hpcgi::UsageError>("corrupted " + file + ": checksum mismatch");
  hpcgi::comm::agreed([&] { check_form_factor_values(rows.values.data(), rows.rows(), info.n, rows.first_row(), path); });
  if (stats) *stats = st;
  return rows;
}

}  // namespace radiosity::dist
