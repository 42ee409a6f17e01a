// Helpers shared by the scene tests: where RRV's scenes and ours are, a scratch folder, and a check that a load
// is refused with a one-line hpcgi::UsageError that says what and where.
#pragma once
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "common/errors.hpp"
#include "radiosity/mesh.hpp"

namespace scene_test {

// RRV's shipped scenes: $RRV_SCENES, else ../shared/scenes/rrv relative to the repository root (the tests run
// there).
inline std::string rrv_dir_wanted() {
  const char* env = std::getenv("RRV_SCENES");
  return (env && *env) ? env : "../shared/scenes/rrv";
}

// nullopt when the folder is absent: the tests that need it skip, saying where they looked.
inline std::optional<std::string> rrv_dir() {
  const std::string dir = rrv_dir_wanted();
  if (!std::filesystem::is_regular_file(std::filesystem::path(dir) / "room3.xml")) return std::nullopt;
  return dir;
}

#define REQUIRE_RRV_DIR(var)                                                                                 \
  const std::optional<std::string> var = scene_test::rrv_dir();                                              \
  if (!var)                                                                                                  \
  GTEST_SKIP() << "RRV's scenes not found in " << scene_test::rrv_dir_wanted() << " (set RRV_SCENES to the " \
               << "folder with room3.xml, room2.xml, teapot.obj)"

// Our scenes, relative to the repository root.
inline std::string own_scene(const std::string& name) { return "radiosity/scenes/" + name; }

// A fresh folder under the system's temporary folder, removed with everything in it at the end of the scope.
class TempDir {
 public:
  TempDir() {
    std::string tmpl = (std::filesystem::temp_directory_path() / "scene_tests.XXXXXX").string();
    if (!mkdtemp(tmpl.data())) throw std::runtime_error("mkdtemp failed");
    path_ = tmpl;
  }
  ~TempDir() { std::filesystem::remove_all(path_); }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// Sets (or with nullptr unsets) an environment variable for the scope, restoring it afterwards.
class EnvGuard {
 public:
  EnvGuard(const char* name, const char* value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    value ? setenv(name, value, 1) : unsetenv(name);
  }
  ~EnvGuard() { old_ ? setenv(name_.c_str(), old_->c_str(), 1) : unsetenv(name_.c_str()); }

 private:
  std::string name_;
  std::optional<std::string> old_;
};

// `load` must throw hpcgi::UsageError whose message is one line containing every one of `parts`.
inline void expect_refused(const std::function<void()>& load, const std::vector<std::string>& parts) {
  try {
    load();
    ADD_FAILURE() << "loaded, expected a UsageError containing " << ::testing::PrintToString(parts);
  } catch (const hpcgi::UsageError& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.find('\n'), std::string::npos) << "not one line: " << msg;
    for (const std::string& p : parts) EXPECT_NE(msg.find(p), std::string::npos) << "'" << p << "' not in: " << msg;
  }
}

// Sum of the area-weighted normals: zero for a closed surface (divergence theorem), whatever its shape.
inline radiosity::Vec3 vector_area(const radiosity::Mesh& m) {
  radiosity::Vec3 s;
  for (const radiosity::Patch& p : m.patches) s = s + (p.v[1] - p.v[0]).cross(p.v[2] - p.v[0]) * 0.5;
  return s;
}

inline double total_area(const radiosity::Mesh& m) {
  double a = 0;
  for (const radiosity::Patch& p : m.patches) a += p.area();
  return a;
}

}  // namespace scene_test
