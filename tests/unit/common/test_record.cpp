// The run record: provenance fields, and appends that stay whole lines under concurrent writers.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>

#include "common/cli.hpp"
#include "common/record.hpp"

namespace fs = std::filesystem;

TEST(Record, HasSchemaAndProvenance) {
  auto r = hpcgi::record::make("test");
  EXPECT_EQ(r["schema"], "hpcgi-record/1");
  EXPECT_EQ(hpcgi::record::schema()["properties"]["schema"]["const"], "hpcgi-record/1");
  for (const char* k : {"git_commit", "git_dirty", "compiler", "cxxflags", "host", "cpu_model", "omp_max_threads",
                        "utc"})
    EXPECT_TRUE(r["provenance"].contains(k)) << k;
}

TEST(Record, ConcurrentAppendsNeverInterleave) {
  const fs::path dir = fs::temp_directory_path() / ("hpcgi_rec_" + std::to_string(getpid()));
  fs::remove_all(dir);
  const std::string path = (dir / "sub" / "r.jsonl").string();  // parent folders are created
  const int writers = 6, per = 150;
  for (int w = 0; w < writers; ++w) {
    if (fork() == 0) {
      for (int i = 0; i < per; ++i) {
        nlohmann::json r = {{"writer", w}, {"i", i}, {"pad", std::string(3000, 'x')}};  // > PIPE_BUF
        hpcgi::record::append(path, r);
      }
      _exit(0);
    }
  }
  for (int w = 0; w < writers; ++w) {
    int st = 0;
    wait(&st);
    ASSERT_TRUE(WIFEXITED(st) && WEXITSTATUS(st) == 0);
  }
  std::ifstream in(path);
  std::string line;
  std::set<std::pair<int, int>> seen;
  while (std::getline(in, line)) {
    auto j = nlohmann::json::parse(line);  // throws on a broken line
    seen.insert({j["writer"].get<int>(), j["i"].get<int>()});
  }
  EXPECT_EQ(seen.size(), static_cast<size_t>(writers * per));
  fs::remove_all(dir);
}

TEST(Record, UnwritablePathThrows) {
  EXPECT_THROW(hpcgi::record::append("/proc/no/such/dir/r.jsonl", {{"a", 1}}), std::exception);
}

TEST(Cli, PositiveFiniteValidator) {
  auto v = hpcgi::positive_finite();
  for (std::string ok : {"1e-6", "0.5", "3"}) EXPECT_EQ(v(ok), "") << ok;
  for (std::string bad : {"nan", "NaN", "inf", "-inf", "0", "-1", "abc", "1e-6x", ""}) EXPECT_NE(v(bad), "") << bad;
}
