// Replays the fuzzing corpus (tests/fuzz/: hand-made seeds and every input the fuzzers turned up) through the two
// loaders in `make test`, under the sanitizers too, so a fixed crash stays fixed. Every file must load or be
// refused with a one-line hpcgi::UsageError; anything else (another exception, a crash, a sanitizer report) fails.
// Seeds named bad_* must be refused and the other seeds must load, so the corpus also keeps its meaning.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "common/errors.hpp"
#include "radiosity/formfactor/file/format.hpp"
#include "radiosity/scene/rrv_reader.hpp"
#include "tests/fuzz/fuzz_setup.hpp"

namespace fs = std::filesystem;

namespace {

enum class Outcome { loaded, refused };

struct Result {
  Outcome outcome;
  std::string message;  // the refusal
};

std::vector<fs::path> files_in(const fs::path& dir) {
  std::vector<fs::path> out;
  if (fs::is_directory(dir))
    for (const auto& e : fs::directory_iterator(dir))
      if (e.is_regular_file()) out.push_back(e.path());
  return out;
}

std::string contents(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

// Runs load; an exception other than UsageError escapes and fails the test with its message.
Result outcome(const fs::path& file, const std::function<void()>& load) {
  try {
    load();
    return {Outcome::loaded, ""};
  } catch (const hpcgi::UsageError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.find_first_of("\r\n"), std::string::npos) << file << ": refusal of more than one line: " << what;
    return {Outcome::refused, what};
  }
}

// Seeds say by their name what must happen: bad_* is refused, anything else loads.
void expect_seed(const fs::path& file, const Result& got) {
  const bool bad = file.filename().string().rfind("bad_", 0) == 0;
  EXPECT_EQ(got.outcome, bad ? Outcome::refused : Outcome::loaded) << file << " " << got.message;
}

// As the fuzzer ran them; the teapot primitive reads RRV's teapot.obj, and where RRV's scenes are absent a seed
// with a teapot is refused.
radiosity::LoadOptions scene_options() {
  radiosity::LoadOptions opt = fuzz::scene_options();
  opt.primitive_dir = "../shared/scenes/rrv";
  return opt;
}

bool needs_missing_teapot(const std::string& xml) {
  return xml.find("<teapot") != std::string::npos && !fs::exists("../shared/scenes/rrv/teapot.obj");
}

}  // namespace

TEST(ReplayCorpus, SceneSeeds) {
  const auto seeds = files_in("tests/fuzz/seeds/scene");
  ASSERT_GE(seeds.size(), 10u) << "the scene seed corpus is missing (run from the repository root)";
  for (const fs::path& f : seeds) {
    const std::string xml = contents(f);
    const Result got = outcome(f, [&] { radiosity::load_rrv_scene_string(xml, scene_options(), f.string()); });
    if (!needs_missing_teapot(xml)) expect_seed(f, got);
  }
}

TEST(ReplayCorpus, SceneRegressions) {
  const auto found = files_in("tests/fuzz/regressions/scene");
  ASSERT_FALSE(found.empty());
  for (const fs::path& f : found)
    outcome(f, [&] { radiosity::load_rrv_scene_string(contents(f), scene_options(), f.string()); });
}

TEST(ReplayCorpus, FormFactorSeeds) {
  const radiosity::Mesh mesh = fuzz::ff_mesh();
  const auto seeds = files_in("tests/fuzz/seeds/ff_file");
  ASSERT_GE(seeds.size(), 10u) << "the form-factor seed corpus is missing (tests/fuzz/make_ff_seeds writes it)";
  for (const fs::path& f : seeds) expect_seed(f, outcome(f, [&] { radiosity::load_form_factors(f.string(), mesh); }));
}

// The seed writer follows the layout documented in radiosity/formfactor/file/format.hpp, not the C++ code: a file it calls valid must read
// back to the values it wrote, which checks the documentation as well.
TEST(ReplayCorpus, FormFactorSeedReadsBackItsValues) {
  const radiosity::FormFactors ff = radiosity::load_form_factors("tests/fuzz/seeds/ff_file/valid_exact", fuzz::ff_mesh());
  ASSERT_EQ(ff.n, 4u);
  EXPECT_EQ(ff(0, 2), 0.1f);
  EXPECT_EQ(ff(0, 0), 0.0f);
  EXPECT_EQ(ff.params.resolution, 256);
}

TEST(ReplayCorpus, FormFactorRegressions) {
  const radiosity::Mesh mesh = fuzz::ff_mesh();
  for (const fs::path& f : files_in("tests/fuzz/regressions/ff_file"))
    outcome(f, [&] { radiosity::load_form_factors(f.string(), mesh); });
}
