#include "radiosity/relight/basis_file.hpp"

#include <cstdio>
#include <cstring>
#include <fstream>
#include <vector>

#include "common/comm.hpp"
#include "common/files.hpp"
#include "common/errors.hpp"
#include "radiosity/formfactor/file/format.hpp"

namespace radiosity::relight {
namespace {

constexpr char kMagic[8] = {'H', 'P', 'C', 'G', 'I', 'R', 'B', '\0'};
constexpr uint32_t kVersion = 1;

template <class T>
void put(std::vector<char>& b, T v) {
  const char* p = reinterpret_cast<const char*>(&v);
  b.insert(b.end(), p, p + sizeof v);
}

struct Reader {
  const std::vector<char>& b;
  const std::string& path;
  size_t at = 0;
  template <class T>
  T get() {
    if (at + sizeof(T) > b.size())
      throw hpcgi::UsageError(path + ": truncated light-basis file (" + std::to_string(b.size()) + " bytes)");
    T v;
    std::memcpy(&v, b.data() + at, sizeof v);
    at += sizeof v;
    return v;
  }
};

}  // namespace

uint64_t colours_hash(const Mesh& m) {
  Fnv64 h;
  for (const Patch& p : m.patches) {
    h.update(p.emission.data(), sizeof p.emission);
    h.update(p.reflectivity.data(), sizeof p.reflectivity);
  }
  return h.finish();
}

BasisKey basis_key(const Mesh& m, const FormFactorFile& ff) {
  return {m.size(), mesh_hash(m), ff.checked(m).stored_checksum(), colours_hash(m)};
}

void save_basis(const std::string& path, const BasisKey& key, const LightBasis& basis) {
  std::vector<char> b(kMagic, kMagic + 8);
  put(b, kVersion);
  put(b, uint32_t(basis.lights.size()));
  put(b, uint64_t(key.n));
  put(b, key.mesh);
  put(b, key.form_factors);
  put(b, key.colours);
  put(b, basis.tol);
  put(b, basis.max_residual);
  put(b, uint64_t(basis.iterations));
  for (const std::string& name : basis.lights) {
    put(b, uint32_t(name.size()));
    b.insert(b.end(), name.begin(), name.end());
  }
  for (const auto& B : basis.B) {
    const char* p = reinterpret_cast<const char*>(B.data());
    b.insert(b.end(), p, p + 8 * B.size());
  }
  Fnv64 h;
  h.update(b.data(), b.size());
  put(b, h.finish());
  hpcgi::files::AtomicFile out(path);  // a unique temporary file beside it, renamed over it when whole
  if (std::fwrite(b.data(), 1, b.size(), out.stream()) != b.size()) out.fail(std::strerror(errno));
  out.commit();
}

LightBasis load_basis(const std::string& path, const BasisKey& key, const std::vector<NamedEntity>& lights) {
  hpcgi::files::require_input(path, "light-basis file");
  std::ifstream f(path, std::ios::binary);
  if (!f) throw hpcgi::UsageError(path + ": cannot open the light-basis file");
  const std::vector<char> b((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  Reader r{b, path};
  if (b.size() < 8 || std::memcmp(b.data(), kMagic, 8) != 0) throw hpcgi::UsageError(path + ": not a light-basis file");
  r.at = 8;
  const uint32_t version = r.get<uint32_t>();
  if (version != kVersion)
    throw hpcgi::UsageError(path + ": light-basis format version " + std::to_string(version) + ", this program reads " +
                            std::to_string(kVersion));
  const uint32_t k = r.get<uint32_t>();
  const uint64_t n = r.get<uint64_t>(), mesh = r.get<uint64_t>(), ff = r.get<uint64_t>(), colours = r.get<uint64_t>();
  if (n != key.n || mesh != key.mesh)
    throw hpcgi::UsageError(path + ": a light basis for another mesh (" + std::to_string(n) + " patches, hash " +
                            std::to_string(mesh) + "; this scene: " + std::to_string(key.n) + ", " +
                            std::to_string(key.mesh) + ")");
  if (ff != key.form_factors)
    throw hpcgi::UsageError(path + ": a light basis for other form factors (checksum " + std::to_string(ff) +
                            ", the --ff file's " + std::to_string(key.form_factors) + ")");
  if (colours != key.colours)
    throw hpcgi::UsageError(path + ": a light basis for other emissions or reflectivities than the scene's");
  LightBasis basis;
  basis.n = n;
  basis.tol = r.get<double>();
  basis.max_residual = r.get<double>();
  r.get<uint64_t>();  // the steps of the solve that made it: not this run's
  for (uint32_t l = 0; l < k; ++l) {
    const uint32_t len = r.get<uint32_t>();
    if (len > 4096 || r.at + len > b.size()) throw hpcgi::UsageError(path + ": truncated or corrupt light-basis file");
    basis.lights.emplace_back(b.data() + r.at, len);
    r.at += len;
  }
  bool same = basis.lights.size() == lights.size();
  for (size_t l = 0; same && l < lights.size(); ++l) same = basis.lights[l] == lights[l].name;
  if (!same) throw hpcgi::UsageError(path + ": its lights are not the scene's lights");
  const uint64_t values = uint64_t(k) * 3 * n * 8;
  if (b.size() != r.at + values + 8)
    throw hpcgi::UsageError(path + ": light-basis file of " + std::to_string(b.size()) + " bytes, its header says " +
                            std::to_string(r.at + values + 8));
  Fnv64 h;
  h.update(b.data(), r.at + values);
  uint64_t sum;
  std::memcpy(&sum, b.data() + r.at + values, 8);
  if (sum != h.finish()) throw hpcgi::UsageError(path + ": checksum mismatch (the light-basis file is corrupt)");
  for (uint32_t l = 0; l < k; ++l) {
    std::vector<double>& B = basis.B.emplace_back(3 * n);
    std::memcpy(B.data(), b.data() + r.at + l * 3 * n * 8, 3 * n * 8);
  }
  basis.pack();
  return basis;
}

LightBasis load_or_solve_basis(const std::string& path, const Mesh& m, const FormFactorFile& ff,
                               const FFMatrixView& F, const std::vector<NamedEntity>& lights, const BasisOptions& opt,
                               bool* loaded) {
  const BasisKey key = basis_key(m, ff);
  *loaded = !path.empty() && std::ifstream(path, std::ios::binary).good();
  if (*loaded) return load_basis(path, key, lights);
  LightBasis b = solve_light_basis(m, F, lights, opt);
  if (!path.empty() && hpcgi::comm::root()) save_basis(path, key, b);  // backend mpi: rank 0 writes it
  return b;
}

}  // namespace radiosity::relight
