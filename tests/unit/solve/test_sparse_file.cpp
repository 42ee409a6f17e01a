// The sparse form-factor file (radiosity/formfactor/file/sparse.hpp): read back to the bit, and damaged files refused.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <random>
#include <string>

#include "common/errors.hpp"
#include "radiosity/formfactor/file/format.hpp"
#include "radiosity/scene/analytic.hpp"
#include "radiosity/solve/host/csr_kernels.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"
#include "radiosity/formfactor/file/sparse.hpp"
#include "radiosity/solve/solve.hpp"
#include "radiosity/solve/storage_choice.hpp"
#include "configs.hpp"
#include "reference.hpp"
#include "sparse_problems.hpp"

using namespace radiosity;
using namespace solve_test;
using namespace sparse_test;

// The sparse form-factor file (version 2): what is written is read back to the bit, and solves as the matrix it was
// made from; a damaged file is refused with one line, and the dense readers refuse a sparse file.
class SparseFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::path(::testing::TempDir()) /
           ("hpcgi_sparse_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
    mesh_ = two_facing_squares(6);
    p_.emplace(occluded_problem(mesh_.size(), 79, 0.75));
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  FormFactorMatrix every_row(FFStorage st, FFValues v) const {
    FFMatrixOptions o;
    o.storage = st;
    o.values = v;
    return FormFactorMatrix(p().F.data(), p().sys.n, std::vector<Rgb>(p().sys.n, Rgb{1, 1, 1}), o);
  }
  std::string bytes_of(const std::string& f) const {
    std::ifstream in(f, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }
  void write_bytes(const std::string& f, const std::string& b) const {
    std::ofstream(f, std::ios::binary | std::ios::trunc).write(b.data(), std::streamsize(b.size()));
  }
  // The file's bytes d with the payload's checksum made right again (so that the structure checks are reached).
  static std::string with_checksum(std::string d) {
    Fnv64 sum;
    sum.update(d.data() + kFormFactorHeaderBytes, d.size() - kFormFactorHeaderBytes - 8);
    const uint64_t h = sum.finish();
    std::memcpy(&d[d.size() - 8], &h, 8);
    return d;
  }
  // The message of the refusal to load f (empty if it loads).
  std::string refusal(const std::string& f) const {
    try {
      load_form_factor_matrix(f, mesh_, nullptr);
    } catch (const hpcgi::UsageError& e) {
      return e.what();
    }
    return "";
  }
  std::filesystem::path dir_;
  Mesh mesh_;
  std::optional<Problem> p_;
  const Problem& p() const { return *p_; }
  HemicubeParams params_{64, HemicubeWeights::exact, 0};
};

TEST_F(SparseFile, RoundTripKeepsEveryBitAndSolvesTheSame) {
  for (FFStorage st : {FFStorage::csr, FFStorage::compressed, FFStorage::runs})
    for (FFValues v : {FFValues::float32, FFValues::float16, FFValues::bfloat16}) {
      SCOPED_TRACE(std::string(to_string(st)) + " " + to_string(v));
      const FormFactorMatrix m = every_row(st, v);
      const std::string f = path("f.ff");
      save_form_factor_matrix(f, mesh_, params_, m);
      const size_t entries = size_t(m.view().row_start[m.view().n]);
      EXPECT_EQ(double(std::filesystem::file_size(f)),
                double(kFormFactorHeaderBytes) + sparse_payload_bytes(st, v, m.view().n, entries, m.runs().runs) + 8);
      HemicubeParams read_params;
      const FormFactorMatrix back = load_form_factor_matrix(f, mesh_, &read_params);
      EXPECT_EQ(read_params.resolution, 64);
      EXPECT_EQ(back.kept(), m.kept());
      EXPECT_EQ(back.bridges(), m.bridges());
      EXPECT_EQ(back.runs().runs, m.runs().runs);
      EXPECT_EQ(back.bytes(), m.bytes());
      EXPECT_EQ(back.view().scale, m.view().scale);
      const SolveConfig c = config("openmp", "aos", "float", 16);
      EXPECT_EQ(solve(system_of(p(), back), c).B, solve(system_of(p(), m), c).B);
      EXPECT_THROW(check_form_factor_file(f, mesh_), hpcgi::UsageError);  // the dense readers refuse it
      try {
        load_form_factors(f, mesh_);
        ADD_FAILURE() << "a dense reader loaded a sparse file";
      } catch (const hpcgi::UsageError& e) {
        EXPECT_NE(std::string(e.what()).find("version 2"), std::string::npos) << e.what();
      }
    }
}

TEST_F(SparseFile, DamagedFilesAreRefused) {
  const std::string f = path("f.ff");
  save_form_factor_matrix(f, mesh_, params_, every_row(FFStorage::compressed, FFValues::float16));
  const std::string good = bytes_of(f);
  std::string b = good;
  b[good.size() - 20] ^= 1;  // a value's bit
  write_bytes(f, b);
  EXPECT_NE(refusal(f).find("checksum mismatch"), std::string::npos) << refusal(f);
  write_bytes(f, good.substr(0, good.size() - 3));
  EXPECT_NE(refusal(f).find("truncated"), std::string::npos) << refusal(f);
  // A step that takes a row past the last column, with its checksum made right: the structure check refuses it.
  b = good;
  const size_t n = mesh_.size(), steps_at = kFormFactorHeaderBytes + 32 + 8 * (n + 1);
  b[steps_at] = char(0xff), b[steps_at + 1] = char(0xff);
  write_bytes(f, with_checksum(b));
  EXPECT_NE(refusal(f).find("column 65534"), std::string::npos) << refusal(f);
  // a dense file is no sparse one
  FormFactors dense{n, p().F, params_};
  save_form_factors(f, mesh_, dense);
  EXPECT_NE(refusal(f).find("version 1"), std::string::npos) << refusal(f);
}

// A runs file is checked as csr and compressed files are: its checksum, and with the checksum made right, runs that
// do not cover their row's values or that take a row past its last column.
TEST_F(SparseFile, DamagedRunsFilesAreRefused) {
  const std::string f = path("f.ff");
  save_form_factor_matrix(f, mesh_, params_, every_row(FFStorage::runs, FFValues::float16));
  const std::string good = bytes_of(f);
  std::string b = good;
  b[good.size() - 20] ^= 1;  // a value's bit
  write_bytes(f, b);
  EXPECT_NE(refusal(f).find("checksum mismatch"), std::string::npos) << refusal(f);
  const size_t n = mesh_.size(), runs_at = kFormFactorHeaderBytes + 32 + 8 * (n + 1) + 8 + 8 * (n + 1);
  b = good;
  b[runs_at + 2] = char(b[runs_at + 2] + 1);  // the first run one value longer than its row holds
  write_bytes(f, with_checksum(b));
  EXPECT_NE(refusal(f).find("runs of"), std::string::npos) << refusal(f);
  b = good;
  b[runs_at] = char(0xff), b[runs_at + 1] = char(0xff);  // the first run starts past the last column
  write_bytes(f, with_checksum(b));
  EXPECT_NE(refusal(f).find("column 65535"), std::string::npos) << refusal(f);
  b = good;
  b[kFormFactorHeaderBytes + 32] ^= 1;  // the count of runs
  write_bytes(f, with_checksum(b));
  EXPECT_NE(refusal(f).find("runs) in a payload"), std::string::npos) << refusal(f);
  write_bytes(f, good);
  EXPECT_EQ(refusal(f), "");
}
