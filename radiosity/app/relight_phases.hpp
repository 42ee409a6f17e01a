// The phases of `bin/radiosity relight` (relight_cmd.cpp runs them in this order): plan (the request refused before
// anything is read), load (scene, frames, form factors and their stored copy), serve (each frame from the light basis
// or solved warm from the previous one) and report (the record and the printed summary).
#pragma once
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/errors.hpp"
#include "radiosity/app/commands.hpp"
#include "radiosity/relight/basis.hpp"
#include "radiosity/relight/entities.hpp"
#include "radiosity/relight/frames.hpp"
#include "radiosity/render/camera.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"

namespace radiosity::app {

struct RelightPlan {
  FFValues values = FFValues::float32;  // --ff-precision of the reflectivity frames
  std::optional<FFStorage> storage;     // --storage; none: auto (storage_choice.hpp, by the frames' values)
  int width = 0, height = 0;            // --size of --png-frames
};
// Throws hpcgi::UsageError for a request that cannot run: the picture size, the reflectivity frames' backend and
// what it reads, the files.
RelightPlan plan_relight(const RelightArgs& a);

struct RelightInputs {
  Mesh m;
  std::vector<relight::NamedEntity> named, lights;
  std::vector<relight::Frame> frames;  // every frame read and checked before anything is computed
  Camera cam;
  FormFactorFile ff_file;                         // --ff, checked against m
  std::unique_ptr<FormFactorMatrix> file_matrix;  // its dense float32 values, as read
  // F in --storage: the reflectivity frames' (and --bench-rhs's) in --ff-precision, the light basis's in float32;
  // none where that is the file's dense float32. A sparse one holds the rows of every patch the scene or a frame
  // makes reflective (reflective_somewhere).
  FFStorage storage = FFStorage::dense;
  std::unique_ptr<FormFactorMatrix> matrix, basis_matrix;
  FFMatrixView file_view, frame_view, basis_view;  // F as read, as the reflectivity frames and the basis read it
  double frame_bytes = 0;                          // what frame_view holds
  double load_s = 0, ff_load_s = 0, ff_build_s = 0;
};
// The scene's reflectivity, and for a patch it gives 0 the first non-zero one a frame gives it: the rows a sparse F
// must hold so that every frame reads F's row of every reflective patch.
std::vector<Rgb> reflective_somewhere(const Mesh& m, const std::vector<relight::NamedEntity>& named,
                                      const std::vector<relight::Frame>& frames);
// "runs (auto: ...)" or "runs": the storage as the summaries print it.
std::string storage_words(const RelightPlan& p, const RelightInputs& in);

// Fills `in` in place (the views point into its form factors); the memory check comes before F is read.
void load_relight(const RelightArgs& a, const RelightPlan& p, RelightInputs& in);

struct ServedFrames {
  std::vector<double> all_ms, basis_ms, solved_ms;
  double worst_error = 0, worst_residual = 0;
  long checked = 0, solved = 0, over_tol = 0;
  hpcgi::Outcome outcome;  // 4 when a solved frame stopped at --max-iter (not at --frame-budget-ms); 3 when one
                           // failed (NaN, breakdown, divergence, no solution) or any frame's radiosity is not
                           // finite (a light of intensity 1e39): the frames stop at that one
  nlohmann::json per_frame = nlohmann::json::array();
  std::vector<std::string> pngs;
};
// Where --png-frames PREFIX puts frame k: PREFIX_kkkk.png (4 digits at least).
std::string png_frame_file(const std::string& prefix, size_t k);

// Serves every frame in order, each warm from the one before (the first from the scene as it is).
ServedFrames serve_frames(const RelightArgs& a, const RelightPlan& p, const RelightInputs& in,
                          const relight::LightBasis& basis);

// The p-th percentile (0..100) of v, the nearest rank; 0 for none.
double percentile(std::vector<double> v, double p);

// The record's params, result and times, and the printed summary.
void relight_record(nlohmann::json& rec, const RelightArgs& a, const RelightInputs& in, const relight::LightBasis& basis,
                    bool basis_loaded, const ServedFrames& s, double total_s);
void print_relight_summary(const RelightArgs& a, const RelightPlan& p, const RelightInputs& in, const relight::LightBasis& basis,
                           bool basis_loaded, const ServedFrames& s);

}  // namespace radiosity::app
