// The relighting's pieces against references they do not share code with: the k-right-hand-side product against k
// single products (affine_matvec), the light basis against solve() of the mixed emission in float64, the basis file's
// refusals, and the frames file's refusals.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "common/errors.hpp"
#include "radiosity/formfactor/file/format.hpp"
#include "radiosity/relight/basis.hpp"
#include "radiosity/relight/basis_file.hpp"
#include "radiosity/relight/frames.hpp"
#include "radiosity/solve/host/exec.hpp"
#include "tests/unit/relight/relight_test_util.hpp"
#include "radiosity/solve/host/linalg.hpp"
#include "radiosity/solve/solve.hpp"

using namespace radiosity;
using radiosity::test::rel_diff;
using radiosity::test::uniform;
using namespace radiosity::relight;

namespace {

// n patches in `entities` instances, the first `lights` of them emitting; F random with rows summing to about 0.9.
struct Scene {
  Mesh m;
  std::vector<float> F;
};
Scene make_scene(size_t n, size_t entities, size_t lights, uint64_t seed) {
  Scene s;
  uint64_t r = seed;
  for (size_t e = 0; e < entities; ++e) {
    s.m.entities.push_back("shape");
    s.m.instances.push_back("obj." + std::to_string(e + 1));
  }
  for (size_t i = 0; i < n; ++i) {
    Patch p;
    p.entity = int(i * entities / n);
    p.v = {Vec3{double(i), 0, 0}, Vec3{double(i) + 1, 0, 0}, Vec3{double(i), 1, 0}};
    for (int c = 0; c < 3; ++c) p.reflectivity[c] = 0.3 + 0.6 * uniform(r);
    if (size_t(p.entity) < lights)
      for (int c = 0; c < 3; ++c) p.emission[c] = 0.5 + uniform(r);
    s.m.patches.push_back(p);
  }
  s.F.resize(n * n);
  for (size_t i = 0; i < n; ++i)
    for (size_t j = 0; j < n; ++j) s.F[i * n + j] = i == j ? 0.0f : float(2 * 0.9 / double(n) * uniform(r));
  return s;
}

}  // namespace

// Every k (16: two full groups), every stored precision of dense F, with skipped rows (reflectivity 0): the k-RHS
// product over F's row blocks gives each right-hand side what the single product gives it, to the rounding of float
// sums in another order.
TEST(MultiProduct, EqualsSingleProducts) {
  const size_t n = 1237;  // not a multiple of the chunk, the group or the row alignment
  Scene s = make_scene(n, 5, 1, 7);
  s.m.patches[17].reflectivity = {0, 0, 0};
  s.m.patches[800].reflectivity = {0, 0, 0};
  std::vector<Rgb> rho(n);
  for (size_t i = 0; i < n; ++i) rho[i] = s.m.patches[i].reflectivity;
  const std::vector<int32_t> rows = dense_rows_to_compute(rho);
  ASSERT_EQ(rows.size(), n - 2);
  const OpenMPExec ex(2);
  for (FFValues v : {FFValues::float32, FFValues::float16, FFValues::bfloat16}) {
    FFMatrixOptions opt;
    opt.values = v;
    const FormFactorMatrix M(s.F.data(), n, rho, opt);
    for (size_t k : {1, 2, 5, 16}) {
      uint64_t r = 99 + k;
      std::vector<Soa<float>> X, Y, E;
      std::vector<std::vector<Rgb>> xh(k), eh(k);
      Soa<float> rs(n);
      load(ex, rs, rho);
      for (size_t q = 0; q < k; ++q) {
        xh[q].resize(n), eh[q].resize(n);
        for (size_t i = 0; i < n; ++i)
          for (int c = 0; c < 3; ++c) xh[q][i][c] = uniform(r), eh[q][i][c] = uniform(r);
        X.emplace_back(n), Y.emplace_back(n), E.emplace_back(n);
        load(ex, X.back(), xh[q]), load(ex, E.back(), eh[q]);
      }
      const RowBlockMatrix B(M.view(), rows, 2);
      multi_affine_matvec<OpenMPExec, float>(ex, B, X, Y, rs, E, 0.5f, 0.9f, 1.0f);
      for (size_t q = 0; q < k; ++q) {
        Aos<float> x(n), y(n), e(n), ra(n);
        load(ex, x, xh[q]), load(ex, e, eh[q]), load(ex, ra, rho);
        affine_matvec(ex, M.view(), rows, x, y, ra, e, 0.5f, 0.9f, 1.0f);
        std::vector<Rgb> want, got;
        store(ex, y, want);
        store(ex, Y[q], got);
        EXPECT_LT(rel_diff(got, want), 2e-6) << to_string(v) << " k=" << k << " q=" << q;
        for (size_t i : {size_t(17), size_t(800)})  // a·x + d·e exactly on a row without reflection
          for (int c = 0; c < 3; ++c) EXPECT_EQ(got[i][c], float(0.5f * float(xh[q][i][c]) + float(eh[q][i][c])));
      }
    }
  }
}

// B is linear in E: a mix from the basis equals a float64 solve of the mixed emission.
TEST(LightBasis, MixEqualsSolveOfTheMixedEmission) {
  const size_t n = 600;
  const Scene s = make_scene(n, 6, 3, 11);
  const std::vector<NamedEntity> named = named_entities(s.m), lights = lights_of(named);
  ASSERT_EQ(lights.size(), 3u);
  BasisOptions opt;
  opt.tol = 1e-10;
  opt.threads = 2;
  const LightBasis b = solve_light_basis(s.m, dense_float32_view(s.F.data(), n), lights, opt);
  EXPECT_LE(b.max_residual, 1e-10);
  EXPECT_GT(b.iterations, 5);
  uint64_t r = 5;
  for (int trial = 0; trial < 5; ++trial) {
    std::vector<LightSetting> set(3);
    for (LightSetting& l : set) {
      l.intensity = 2 * uniform(r);
      for (double& c : l.colour) c = uniform(r);
    }
    std::vector<float> mixed;
    mix(b, set, mixed, 1);
    std::vector<Rgb> got(n);
    for (size_t i = 0; i < n; ++i) got[i] = {mixed[3 * i], mixed[3 * i + 1], mixed[3 * i + 2]};
    Mesh fm = s.m;
    const std::vector<Rgb> e = frame_emission(s.m, lights, set);
    for (size_t i = 0; i < n; ++i) fm.patches[i].emission = e[i];
    System sys = make_system(fm, s.F.data());
    SolveConfig cfg;
    cfg.method = Method::bicgstab;
    cfg.precision = Precision::double_;
    cfg.tol = 1e-12;
    const SolveResult ref = solve(sys, cfg);
    ASSERT_EQ(ref.status, SolveStatus::converged);
    EXPECT_LT(rel_diff(got, ref.B), 1e-6) << "trial " << trial;  // float32 storage of the basis and of the sums
  }
}

namespace {

std::string temp_path(const std::string& name) { return ::testing::TempDir() + "relight_" + name; }

void write(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

// A form-factor file for the scene (relight's basis file is tied to its checksum).
std::string ff_file(const Scene& s, const std::string& name) {
  FormFactors ff;
  ff.n = s.m.size();
  ff.values = s.F;
  const std::string path = temp_path(name);
  save_form_factors(path, s.m, ff);
  return path;
}

std::string refusal(const std::function<void()>& f) {
  try {
    f();
  } catch (const hpcgi::UsageError& e) {
    return e.what();
  }
  return "(accepted)";
}

}  // namespace

TEST(BasisFile, RoundTripAndRefusals) {
  const Scene s = make_scene(200, 4, 2, 3);
  const std::vector<NamedEntity> lights = lights_of(named_entities(s.m));
  BasisOptions opt;
  opt.threads = 1;
  const LightBasis b = solve_light_basis(s.m, dense_float32_view(s.F.data(), 200), lights, opt);
  const std::string ff = ff_file(s, "a.ff"), path = temp_path("a.basis");
  save_basis(path, basis_key(s.m, FormFactorFile::open(ff)), b);
  const LightBasis r = load_basis(path, basis_key(s.m, FormFactorFile::open(ff)), lights);
  ASSERT_EQ(r.lights, b.lights);
  EXPECT_EQ(r.B, b.B);
  EXPECT_EQ(r.max_residual, b.max_residual);

  Scene other_ff = s;
  other_ff.F[5] *= 0.5f;
  const std::string ff2 = ff_file(other_ff, "b.ff");
  EXPECT_NE(refusal([&] { load_basis(path, basis_key(s.m, FormFactorFile::open(ff2)), lights); }).find("other form factors"), std::string::npos);
  Scene moved = s;
  moved.m.patches[0].v[0].x += 1e-3;
  const std::string ff3 = ff_file(moved, "c.ff");
  EXPECT_NE(refusal([&] { load_basis(path, basis_key(moved.m, FormFactorFile::open(ff3)), lights); }).find("another mesh"), std::string::npos);
  Scene recoloured = s;
  recoloured.m.patches[3].reflectivity[1] = 0.5;
  EXPECT_NE(refusal([&] { load_basis(path, basis_key(recoloured.m, FormFactorFile::open(ff)), lights); }).find("other emissions"),
            std::string::npos);
  // One flipped byte in the values, and a truncated file.
  std::string bytes;
  {
    std::ifstream f(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
  }
  std::string bad = bytes;
  bad[bad.size() - 100] ^= 1;
  const std::string corrupt = temp_path("corrupt.basis"), cut = temp_path("cut.basis");
  std::ofstream(corrupt, std::ios::binary) << bad;
  std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() - 9);
  EXPECT_NE(refusal([&] { load_basis(corrupt, basis_key(s.m, FormFactorFile::open(ff)), lights); }).find("checksum"), std::string::npos);
  EXPECT_NE(refusal([&] { load_basis(cut, basis_key(s.m, FormFactorFile::open(ff)), lights); }).find("bytes"), std::string::npos);
  EXPECT_NE(refusal([&] { load_basis(ff, basis_key(s.m, FormFactorFile::open(ff)), lights); }).find("not a light-basis file"),
            std::string::npos);
}

TEST(Frames, ReadsStateForwardAndRefusesBadFrames) {
  const Scene s = make_scene(100, 4, 2, 1);
  const std::vector<NamedEntity> named = named_entities(s.m);
  const std::string path = temp_path("frames.json");
  write(path, R"({"frames": [{"lights": {"obj.2": {"intensity": 0.5}}},
                             {"lights": {"obj.1": {"rgb": [1, 0, 0.5]}}, "reflectivity": {"obj.3": [0.2, 0.2, 0.2]}},
                             {}]})");
  const std::vector<Frame> f = read_frames(path, s.m, named, false);
  ASSERT_EQ(f.size(), 3u);
  EXPECT_EQ(f[0].lights[1].intensity, 0.5);
  EXPECT_TRUE(f[0].scene_reflectivity);
  EXPECT_EQ(f[1].lights[1].intensity, 0.5);  // kept from frame 0
  EXPECT_EQ(f[1].lights[0].colour, (Rgb{1, 0, 0.5}));
  EXPECT_FALSE(f[1].scene_reflectivity);
  EXPECT_FALSE(f[2].scene_reflectivity);  // kept from frame 1
  const std::vector<std::pair<std::string, std::string>> bad = {
      {R"({"frames": [{}, {"lights": {"obj.9": {"intensity": 1}}}]})", "frame 1: unknown light 'obj.9'"},
      {R"({"frames": [{"lights": {"obj.1": {"intensity": NaN}}}]})", "malformed JSON at line 1"},
      {R"({"frames": [{}, {}, {"lights": {"obj.1": {"intensity": 1e999}}}]})", "(frame 2)"},
      {R"({"frames": [{"lights": {"obj.1": {"intensity": -1}}}]})", "frame 0: light 'obj.1' intensity is negative"},
      {R"({"frames": [{"reflectivity": {"obj.3": [1, 0, 0]}}]})", ">= 1"},
      {R"({"frames": [{"reflectivity": {"nope": [0, 0, 0]}}]})", "unknown entity 'nope'"},
      {R"({"frames": [{"lights": {"obj.1": {"rgb": [1, 1]}}}]})", "three numbers"},
      {R"({"frames": [{"colour": 1}]})", "unknown key 'colour'"},
      {R"({"frames": [{"reflectivity": {"obj.3": {"scale": 1.7}}}]})", "times 1.7 is >= 1"},
      {R"({"frames": [{"reflectivity": {"obj.3": {"factor": 0.5}}}]})", "[r, g, b] or {\"scale\": f}"},
      {R"([1, 2])", "one object"},
      {R"({"frames": []})", "no frames"},
  };
  for (const auto& [text, want] : bad) {
    write(path, text);
    const std::string why = refusal([&] { read_frames(path, s.m, named, false); });
    EXPECT_NE(why.find(want), std::string::npos) << text << " -> " << why;
    EXPECT_EQ(why.rfind(path, 0), 0u) << why;  // the message starts with the file
  }
  write(path, R"({"frames": [{"reflectivity": {"obj.3": [1, 0, 0]}}]})");
  EXPECT_EQ(read_frames(path, s.m, named, true).size(), 1u);  // with --allow-reflectivity-ge-1
  // A scale multiplies each patch's own reflectivity; scale 1 is the scene again (the basis serves it).
  write(path, R"({"frames": [{"reflectivity": {"obj.3": {"scale": 0.5}}}, {"reflectivity": {"obj.3": {"scale": 1}}}]})");
  const std::vector<Frame> g = read_frames(path, s.m, named, false);
  EXPECT_FALSE(g[0].scene_reflectivity);
  EXPECT_TRUE(g[1].scene_reflectivity);
  const Mesh fm = frame_mesh(s.m, named, g[0]);
  for (size_t i : named[2].patches)
    for (int c = 0; c < 3; ++c) EXPECT_EQ(fm.patches[i].reflectivity[c], 0.5 * s.m.patches[i].reflectivity[c]);
}
