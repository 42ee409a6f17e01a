// The run record: one JSON object per line (JSON Lines), the same schema for every program of the project.
//
//   {"schema": "hpcgi-record/1", "app": ..., "params": {...}, "result": {...}, "times_s": {...},
//    "perf": {...}, "backend_info": {...}, "provenance": {...}}
//
// pandas.json_normalize flattens it to one row with columns such as "params.n" and "times_s.solve".
#pragma once
#include <nlohmann/json.hpp>

#include <string>

namespace hpcgi::record {

inline constexpr const char* kSchema = "hpcgi-record/1";

// What built this binary and where it runs: git commit and dirty flag, compiler and flags, CPU model, host,
// OpenMP threads, Slurm job/array ids, UTC time. Backends add their own (MPI library, GPU) in backend_info.
nlohmann::json provenance();

// Remembers the program's command line (main calls it first); records carry it as "argv", so that an audit can
// run the same case again.
void set_command_line(int argc, char** argv);

// A new record with schema, app, argv and provenance filled in.
nlohmann::json make(const std::string& app);

// Appends `rec` as one line to `path` (parent folders are created). The line is written by one write() under an
// exclusive flock, so concurrent writers never interleave; if the write fails the file is cut back to its old
// length, so a reader never sees half a line. Throws std::runtime_error on failure.
void append(const std::string& path, const nlohmann::json& rec);

}  // namespace hpcgi::record
