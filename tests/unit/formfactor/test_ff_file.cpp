// The form-factor file: a round trip keeps every bit, and every way a file can be wrong is refused with a message
// that says what is wrong.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "common/errors.hpp"
#include "radiosity/formfactor/file/format.hpp"
#include "radiosity/scene/analytic.hpp"

using namespace radiosity;
namespace fs = std::filesystem;

namespace {

class FormFactorFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) /
           ("hpcgi_ff_" + std::to_string(getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
    mesh_ = two_facing_squares(2);
    ff_.n = mesh_.size();
    ff_.params = {64, HemicubeWeights::rrv2007, 1e-4};
    for (size_t k = 0; k < ff_.n * ff_.n; ++k) ff_.values.push_back(k % (ff_.n + 1) ? 1.0f / (3 + k) : 0.0f);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  std::string bytes_of(const std::string& p) const {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }
  void write_bytes(const std::string& p, const std::string& b) const {
    std::ofstream(p, std::ios::binary | std::ios::trunc).write(b.data(), std::streamsize(b.size()));
  }

  // The UsageError's message when loading p for the mesh m ("" if it loads).
  std::string refusal(const std::string& p, const Mesh& m) const {
    try {
      load_form_factors(p, m);
    } catch (const hpcgi::UsageError& e) {
      return e.what();
    }
    return "";
  }

  // Files in the test's folder (a writer's temporary file would be one more).
  size_t entries() const { return std::distance(fs::directory_iterator(dir_), fs::directory_iterator()); }

  fs::path dir_;
  Mesh mesh_;
  FormFactors ff_;
};

const size_t kHeader = 72;

}  // namespace

TEST_F(FormFactorFile, RoundTripKeepsValuesAndParameters) {
  const std::string p = path("scene.ff");
  save_form_factors(p, mesh_, ff_);
  EXPECT_EQ(entries(), 1u);  // the file and no temporary one
  EXPECT_EQ(fs::file_size(p), kHeader + 4 * ff_.n * ff_.n + 8);
  EXPECT_EQ(bytes_of(p).substr(0, 8), std::string("HPCGIFF\0", 8));
  const FormFactors back = load_form_factors(p, mesh_);
  EXPECT_EQ(back.n, ff_.n);
  EXPECT_EQ(back.values, ff_.values);
  EXPECT_EQ(back.params.resolution, 64);
  EXPECT_EQ(back.params.weights, HemicubeWeights::rrv2007);
  EXPECT_EQ(back.params.threshold, 1e-4);
}

TEST_F(FormFactorFile, SavingReplacesAnOldFileWhole) {
  const std::string p = path("scene.ff");
  write_bytes(p, "an older file, about to be replaced");
  save_form_factors(p, mesh_, ff_);
  EXPECT_EQ(load_form_factors(p, mesh_).values, ff_.values);
  EXPECT_EQ(entries(), 1u);
}

TEST_F(FormFactorFile, UnwritableDirectoryIsARuntimeErrorAndLeavesNothing) {
  const std::string p = path("missing/dir/scene.ff");
  EXPECT_THROW(save_form_factors(p, mesh_, ff_), std::runtime_error);
  EXPECT_FALSE(fs::exists(p));
  EXPECT_EQ(entries(), 0u);
}

TEST_F(FormFactorFile, MatrixOfAnotherSizeIsNotSaved) {
  FormFactors wrong = ff_;
  wrong.n = ff_.n - 1;
  EXPECT_THROW(save_form_factors(path("x.ff"), mesh_, wrong), std::invalid_argument);
}

TEST_F(FormFactorFile, MissingFileIsRefused) {
  EXPECT_NE(refusal(path("nowhere.ff"), mesh_).find("cannot open form-factor file"), std::string::npos);
}

TEST_F(FormFactorFile, BadMagicIsRefused) {
  const std::string p = path("scene.xml");
  write_bytes(p, "<?xml version=\"1.0\"?><scene/>");
  EXPECT_NE(refusal(p, mesh_).find("is not a form-factor file (bad magic)"), std::string::npos);
  write_bytes(p, "HPC");  // shorter than the magic
  EXPECT_NE(refusal(p, mesh_).find("bad magic"), std::string::npos);
}

TEST_F(FormFactorFile, UnsupportedVersionIsRefused) {
  const std::string p = path("scene.ff");
  save_form_factors(p, mesh_, ff_);
  std::string b = bytes_of(p);
  uint32_t version = 3;
  std::memcpy(&b[8], &version, 4);
  write_bytes(p, b);
  EXPECT_NE(refusal(p, mesh_).find("version 3 (this program reads versions 1 and 2)"), std::string::npos)
      << refusal(p, mesh_);
  // version 2 is sparse: a dense storage name there is refused
  version = 2;
  std::memcpy(&b[8], &version, 4);
  write_bytes(p, b);
  EXPECT_NE(refusal(p, mesh_).find("storage 'dense', precision 'float32' (version 2 holds csr, compressed or runs"),
            std::string::npos)
      << refusal(p, mesh_);
}

TEST_F(FormFactorFile, FileOfAnotherMeshIsRefusedNamingBoth) {
  const std::string p = path("scene.ff");
  save_form_factors(p, mesh_, ff_);
  // Same patch count, other geometry: the hash tells them apart.
  Mesh moved = mesh_;
  moved.patches[0].v[0].x += 1e-9;
  const std::string hash_msg = refusal(p, moved);
  EXPECT_NE(hash_msg.find("belongs to another mesh"), std::string::npos) << hash_msg;
  char file_hash[32], scene_hash[32];
  std::snprintf(file_hash, sizeof file_hash, "0x%016llx", static_cast<unsigned long long>(mesh_hash(mesh_)));
  std::snprintf(scene_hash, sizeof scene_hash, "0x%016llx", static_cast<unsigned long long>(mesh_hash(moved)));
  EXPECT_NE(hash_msg.find(file_hash), std::string::npos) << hash_msg;
  EXPECT_NE(hash_msg.find(scene_hash), std::string::npos) << hash_msg;
  // Another patch count: both counts are given.
  const std::string count_msg = refusal(p, two_facing_squares(3));
  EXPECT_NE(count_msg.find("the file has 16 patches"), std::string::npos) << count_msg;
  EXPECT_NE(count_msg.find("the scene has 36 patches"), std::string::npos) << count_msg;
}

TEST_F(FormFactorFile, TruncatedFileIsRefusedWithBothSizes) {
  const std::string p = path("scene.ff");
  save_form_factors(p, mesh_, ff_);
  const std::string b = bytes_of(p);
  write_bytes(p, b.substr(0, b.size() - 100));
  const std::string msg = refusal(p, mesh_);
  EXPECT_NE(msg.find("truncated"), std::string::npos) << msg;
  EXPECT_NE(msg.find("expected " + std::to_string(b.size()) + " bytes, found " + std::to_string(b.size() - 100)),
            std::string::npos)
      << msg;
  write_bytes(p, b.substr(0, 40));  // cut inside the header
  EXPECT_NE(refusal(p, mesh_).find("truncated"), std::string::npos);
}

TEST_F(FormFactorFile, CorruptedValueIsRefused) {
  const std::string p = path("scene.ff");
  save_form_factors(p, mesh_, ff_);
  std::string b = bytes_of(p);
  b[kHeader + 4 * 7 + 2] ^= 0x10;
  write_bytes(p, b);
  EXPECT_NE(refusal(p, mesh_).find("checksum mismatch"), std::string::npos);
}

// Found by fuzzing (tests/fuzz/regressions/ff_file): a storage name of carriage returns was quoted raw, so the
// refusal was not one line. Control characters are shown escaped.
TEST_F(FormFactorFile, ControlCharactersInNamesAreQuotedEscaped) {
  const std::string p = path("scene.ff");
  save_form_factors(p, mesh_, ff_);
  std::string b = bytes_of(p);
  std::memcpy(&b[24], "\r\r\nab\t\0", 8);  // the storage field
  write_bytes(p, b);
  const std::string msg = refusal(p, mesh_);
  EXPECT_NE(msg.find("storage '\\x0d\\x0d\\x0aab\\x09'"), std::string::npos) << msg;
  EXPECT_EQ(msg.find_first_of("\r\n\t"), std::string::npos) << msg;
}

// The checksum fed in pieces of any size (an MPI rank's rows, ending inside a 64-bit word when n is odd) is the
// checksum of the whole.
TEST(Fnv64, PiecesGiveTheHashOfTheWhole) {
  std::vector<unsigned char> bytes(1000);
  for (size_t k = 0; k < bytes.size(); ++k) bytes[k] = static_cast<unsigned char>(k * 37 + 11);
  Fnv64 whole;
  whole.update(bytes.data(), bytes.size());
  for (size_t cut1 : {0u, 1u, 4u, 7u, 8u, 12u, 500u})
    for (size_t cut2 : {cut1, cut1 + 3, cut1 + 4, cut1 + 9, size_t(999)}) {
      if (cut2 < cut1 || cut2 > bytes.size()) continue;
      Fnv64 h;
      h.update(bytes.data(), cut1);
      h.update(bytes.data() + cut1, cut2 - cut1);
      h.update(bytes.data() + cut2, bytes.size() - cut2);
      EXPECT_EQ(h.finish(), whole.finish()) << cut1 << ", " << cut2;
    }
  // Odd lengths: the last bytes hashed one by one, as the file's checksum always was.
  Fnv64 a, b;
  a.update(bytes.data(), 13);
  b.update(bytes.data(), 5);
  b.update(bytes.data() + 5, 8);
  EXPECT_EQ(a.finish(), b.finish());
}
