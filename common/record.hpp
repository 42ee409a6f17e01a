// The run record: one JSON object per line (JSON Lines), the same schema for every program of the project.
//
//   {"schema": "hpcgi-record/1", "app": ..., "params": {...}, "result": {...}, "times_s": {...},
//    "perf": {...}, "backend_info": {...}, "provenance": {...}}
//
// pandas.json_normalize flattens it to one row with columns such as "params.n" and "times_s.solve".
#pragma once
#include <nlohmann/json.hpp>

#include <string>

#include "common/errors.hpp"

namespace hpcgi::record {

// The record's one definition, common/record.schema.json (JSON Schema), built into the program: every producer's
// record is checked against it by the tests, and every record analysis/ reads.
const nlohmann::json& schema();
// Its version, "hpcgi-record/1" (the schema's "$id"), which every record carries as "schema".
std::string schema_version();

// What built this binary and where it runs: git commit and dirty flag, compiler and flags, CPU model, host,
// OpenMP threads, Slurm job/array ids, UTC time. Backends add their own (MPI library, GPU) in backend_info.
nlohmann::json provenance();

// Remembers the program's command line (main calls it first); records carry it as "argv", so that an audit can
// run the same case again.
void set_command_line(int argc, char** argv);

// A new record with schema, app, argv and provenance filled in.
nlohmann::json make(const std::string& app);

// Where a run's record goes: --record FILE (appended), --json (printed on stdout), --quiet (nothing else printed).
// Every program takes the three flags from hpcgi::add_record_options (common/cli.hpp).
struct Options {
  std::string record_path;
  bool json = false;
  bool quiet = false;
};

// Seconds since this process began (the kernel's start time of /proc/self/stat, in clock ticks, against
// CLOCK_BOOTTIME): its whole life so far, program loading, MPI and library start-up included; -1 where the system
// does not say. The start is rounded down to a tick (10 ms at the usual 100 Hz), so this never falls short.
double process_seconds();

// The end of every run that makes a record: printed with --json, appended to --record's file, with
// times_s.process = process_seconds() at that moment (everything the program did, before its exit's clean-up).
void emit(const nlohmann::json& rec, const Options& out);

// The run's outcome in its record: result.exit_status (common/errors.hpp) and result.exit_reason (null for 0).
void set_outcome(nlohmann::json& rec, const Outcome& outcome);

// Appends `rec` as one line to `path` (parent folders are created). The line is written by one write() under an
// exclusive flock, so concurrent writers never interleave; if the write fails the file is cut back to its old
// length, so a reader never sees half a line. Throws std::runtime_error on failure.
void append(const std::string& path, const nlohmann::json& rec);

}  // namespace hpcgi::record
