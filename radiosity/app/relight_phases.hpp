// The phases of `bin/radiosity relight` (relight_cmd.cpp runs them in this order): plan (the request refused before
// anything is read), load (scene, frames, form factors and their stored copy), serve (each frame from the light basis
// or solved warm from the previous one) and report (the record and the printed summary).
#pragma once
#include <memory>
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
  FormFactors ff;
  std::unique_ptr<FormFactorMatrix> matrix;  // the reflectivity frames' F in 16 bits, when asked
  FFMatrixView file_view, frame_view;        // F as read, and as the reflectivity frames read it
  double load_s = 0, ff_load_s = 0;
};
// Fills `in` in place (the views point into its form factors); the memory check comes before F is read.
void load_relight(const RelightArgs& a, const RelightPlan& p, RelightInputs& in);

struct ServedFrames {
  std::vector<double> all_ms, basis_ms, solved_ms;
  double worst_error = 0, worst_residual = 0;
  long checked = 0, solved = 0, over_tol = 0;
  hpcgi::Outcome outcome;  // 4 when a solved frame stopped at --max-iter (not at --frame-budget-ms); 3 when one
                           // failed (NaN, breakdown, divergence, no solution): the frames stop at that one
  nlohmann::json per_frame = nlohmann::json::array();
  std::vector<std::string> pngs;
};
// Serves every frame in order, each warm from the one before (the first from the scene as it is).
ServedFrames serve_frames(const RelightArgs& a, const RelightPlan& p, const RelightInputs& in,
                          const relight::LightBasis& basis);

// The p-th percentile (0..100) of v, the nearest rank; 0 for none.
double percentile(std::vector<double> v, double p);

// The record's params, result and times, and the printed summary.
void relight_record(nlohmann::json& rec, const RelightArgs& a, const RelightInputs& in, const relight::LightBasis& basis,
                    bool basis_loaded, const ServedFrames& s, double total_s);
void print_relight_summary(const RelightArgs& a, const RelightInputs& in, const relight::LightBasis& basis,
                           bool basis_loaded, const ServedFrames& s);

}  // namespace radiosity::app
