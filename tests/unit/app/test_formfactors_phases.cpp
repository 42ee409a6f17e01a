// The phases of bin/radiosity formfactors (radiosity/app/formfactors_phases.hpp), one process, on two facing
// squares; and the row range of the form factors they compute and of the matrix a solve holds.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>

#include "common/errors.hpp"
#include "radiosity/app/formfactors_phases.hpp"
#include "radiosity/formfactor/file/format.hpp"
#include "radiosity/formfactor/hemicube.hpp"
#include "radiosity/scene/analytic.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"

using namespace radiosity;
using namespace radiosity::app;

namespace {

std::string temp_path(const char* name);

// The phases take the mesh as given; the scene is only a file that the plan's checks find.
FormFactorArgs args(const std::string& out) {
  FormFactorArgs a;
  a.scene = temp_path("scene.xml");
  std::FILE* f = std::fopen(a.scene.c_str(), "w");
  std::fputs("<scene/>\n", f);
  std::fclose(f);
  a.out = out;
  a.hemicube.resolution = 16;
  a.quiet = true;
  return a;
}

std::string temp_path(const char* name) {
  return (std::filesystem::temp_directory_path() / (std::string("hpcgi_app_") + name)).string();
}

}  // namespace

TEST(FormFactorRowRange, EveryRowByDefaultABlockWhenSet) {
  FormFactors ff{2, {0, 0.25f, 0.5f, 0}, HemicubeParams{}};
  EXPECT_TRUE(ff.all_rows());
  EXPECT_EQ(ff.rows(), 2u);
  EXPECT_EQ(ff(1, 0), 0.5f);
  FormFactors block{4, std::vector<float>(8, 0.1f), HemicubeParams{}, 1, 3};
  block.values[4] = 0.75f;  // row 2, column 0
  EXPECT_FALSE(block.all_rows());
  EXPECT_EQ(block.rows(), 2u);
  EXPECT_EQ(block(2, 0), 0.75f);
}

TEST(FormFactorRowRange, TheMatrixKeepsTheRowsItHolds) {
  FormFactorMatrix::Parts parts;
  parts.n = 4;
  parts.row_begin = 1;
  parts.row_end = 3;
  parts.f32.assign(8, 0.1f);
  FormFactorMatrix m(std::move(parts));
  EXPECT_EQ(m.row_begin(), 1u);
  EXPECT_EQ(m.row_end(), 3u);
  EXPECT_EQ(m.rows(), 2u);
  ASSERT_NE(m.dense_float32_values(), nullptr);
  EXPECT_EQ(m.dense_float32_values()[7], 0.1f);
  FormFactorMatrix whole(std::vector<float>(16, 0).data(), 4, std::vector<Rgb>(4, Rgb{1, 1, 1}), FFMatrixOptions{});
  EXPECT_EQ(whole.rows(), 4u);
}

TEST(FormFactorsPlan, RefusesA16BitDenseFileAndBadHemicube) {
  FormFactorArgs a = args(temp_path("plan.ff"));
  a.ff_precision = "float16";
  EXPECT_THROW(plan_formfactors(a), hpcgi::UsageError);
  a.ff_precision = "float32";
  a.hemicube.resolution = 15;  // odd
  EXPECT_THROW(plan_formfactors(a), hpcgi::UsageError);
  a.hemicube.resolution = 16;
  a.weights = "rrv2007";
  const FormFactorPlan p = plan_formfactors(a);
  EXPECT_EQ(p.hemicube.weights, HemicubeWeights::rrv2007);
  EXPECT_EQ(p.limit, 0);
}

TEST(FormFactorsSplit, OneProcessHoldsEveryRowByCount) {
  const Mesh m = two_facing_squares(3);
  const FormFactorArgs a = args(temp_path("split.ff"));
  const FormFactorSplit s = split_formfactors(a, m, plan_formfactors(a));
  EXPECT_EQ(s.bounds, (std::vector<size_t>{0, m.size()}));
  EXPECT_TRUE(s.by_count);
  EXPECT_FALSE(s.estimate);  // a serial run without --max-memory-per-rank estimates nothing
  const std::vector<size_t> four = s.bounds_for(4);
  ASSERT_EQ(four.size(), 5u);
  EXPECT_EQ(four.back(), m.size());
  const std::vector<RankNeed> needs = s.needs(four);
  ASSERT_EQ(needs.size(), 4u);
  for (const RankNeed& r : needs) EXPECT_DOUBLE_EQ(r.ff_bytes, 4.0 * double(r.rows) * double(m.size()));
}

TEST(FormFactorsComputeWriteReport, TheFileAndTheRecordSayWhatWasComputed) {
  const Mesh m = two_facing_squares(3);
  const std::string out = temp_path("compute.ff");
  const FormFactorArgs a = args(out);
  const FormFactorPlan plan = plan_formfactors(a);
  const FormFactorSplit split = split_formfactors(a, m, plan);
  ComputedRows c = compute_formfactors(a, m, plan, split);
  const FormFactors direct = compute_form_factors(m, plan.hemicube);
  EXPECT_EQ(c.rows.values, direct.values);  // the phase is the hemicube of every row
  EXPECT_TRUE(c.reciprocity);
  EXPECT_GT(c.d.pairs_compared, 0u);
  EXPECT_GT(c.d.min_row_sum, 0);
  EXPECT_LE(c.d.max_row_sum, 1.01);
  EXPECT_GT(c.nonzero, 0u);

  const WriteStats w = write_formfactors(a, m, c.rows);
  EXPECT_EQ(load_form_factors(out, m).values, direct.values);
  const nlohmann::json rec = formfactors_record(a, m, plan, split, c, w, {0.5, 2.0});
  EXPECT_EQ(rec["params"]["command"], "formfactors");
  EXPECT_EQ(rec["params"]["hemicube"], 16);
  EXPECT_EQ(rec["params"]["patches"], m.size());
  EXPECT_FALSE(rec.contains("mpi"));
  EXPECT_EQ(rec["result"]["min_row_sum"], c.d.min_row_sum);
  EXPECT_EQ(rec["result"]["reciprocity_pairs"], c.d.pairs_compared);
  EXPECT_DOUBLE_EQ(rec["result"]["nonzero_fraction"].get<double>(),
                   double(c.nonzero) / (double(m.size()) * double(m.size())));
  EXPECT_EQ(rec["times_s"]["load"], 0.5);
  EXPECT_EQ(rec["times_s"]["total"], 2.0);
  EXPECT_EQ(rec["result"]["file"], out);

  testing::internal::CaptureStdout();
  print_formfactors_summary(a, m, plan, split, c, w, 0.5);
  const std::string text = testing::internal::GetCapturedStdout();
  EXPECT_NE(text.find("formfactors: " + a.scene + ", 36 patches"), std::string::npos) << text;
  EXPECT_NE(text.find("reciprocity error max"), std::string::npos) << text;
  EXPECT_NE(text.find("-> " + out), std::string::npos) << text;
  std::remove(out.c_str());
}
