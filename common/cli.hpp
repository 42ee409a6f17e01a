// Command-line conventions of every program: CLI11 for parsing, "--help" exits 0, any parse error exits 2 with
// one line on stderr, UsageError exits 2, NumericalError 3, NotConvergedError 4, DisagreedError 5, anything else
// exits 1 (common/errors.hpp).
#pragma once
#include <CLI/CLI.hpp>

#include <cmath>
#include <functional>
#include <string>

namespace hpcgi {

namespace record {
struct Options;
}
// --record FILE, --json and --quiet, the same in every program (common/record.hpp: record::emit).
void add_record_options(CLI::App* app, record::Options& out);

// --min-time SECONDS, the same in every program that times a solve (common/repetitions.hpp): 0 (the default) is one
// solve; S > 0 repeats a solve shorter than S in the process and takes the median repetition. At most an hour.
void add_min_time_option(CLI::App* app, double& seconds);

// Runs body() and turns the project's exceptions into exit statuses and one-line messages.
int run_main(const std::string& program, const std::function<int()>& body);

// Parses argv; on --help/--version prints and returns 0 through `exit_code`, on error prints one line and
// returns 2. Returns true when the program should go on.
bool parse_cli(CLI::App& app, int argc, char** argv, int& exit_code);

// --list-backends [--json] on `app`: prints describe(json) on stdout and ends parse_cli with exit status 0, before
// any requirement of the command line (a subcommand) is checked. --json is the app's own where it has one (bin/poisson's
// record option), else added here. The programs' facts about their backends, for the Python that needs them.
void add_list_backends(CLI::App& app, std::function<std::string(bool json)> describe);

// A validator for floating-point options: finite and > 0 (rejects NaN, inf, 0 and negatives).
CLI::Validator positive_finite();

// A relative tolerance must lie in (0, 1) and be reachable in the working precision ("float" or "double"): at or
// above 1 every run "converges" at once, a hundred times below the precision's rounding (FLT_EPSILON, DBL_EPSILON)
// none can.
// Throws UsageError with one line.
void check_tolerance(double tol, const std::string& precision);

// A validator for integer options in [lo, hi], with messages a user reads at a glance: "'16abc' is not an
// integer", "must be an integer from 1 to 4096, got 0" (CLI11's Range prints its bounds with 309 digits).
CLI::Validator integer_in(long long lo, long long hi);

// A validator for a fraction: a finite number with 0 <= v < 1 (a threshold that keeps some form factors).
CLI::Validator fraction_below_one();

// --threads beyond 16 per online CPU is refused: no run gets faster so oversubscribed, and each thread holds a
// stack and its buffers (4096 threads took 2.8 GB of a 12-patch run). 0 (the default) is always fine.
void check_threads(int threads);

// A validator for sizes in bytes ("67108864", "64M", "1.5G": common/memory.hpp's parse_bytes).
CLI::Validator byte_size();

}  // namespace hpcgi
