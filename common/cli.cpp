#include "common/cli.hpp"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <unistd.h>
#include <exception>

#include "common/comm.hpp"
#include "common/errors.hpp"
#include "common/memory.hpp"
#include "common/one_line.hpp"
#include "common/record.hpp"

namespace hpcgi {

void add_record_options(CLI::App* app, record::Options& out) {
  app->add_option("--record", out.record_path, "append one JSON record of this run to FILE (JSON Lines)");
  app->add_flag("--json", out.json, "print the record on stdout");
  app->add_flag("--quiet", out.quiet, "print nothing but errors (and the record with --json)");
}

bool parse_cli(CLI::App& app, int argc, char** argv, int& exit_code) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    exit_code = app.exit(e);  // prints the help on stdout, returns 0
    return false;
  } catch (const CLI::CallForAllHelp& e) {
    exit_code = app.exit(e);
    return false;
  } catch (const CLI::Success&) {  // --list-backends: printed
    exit_code = 0;
    return false;
  } catch (const CLI::ParseError& e) {
    // A program of subcommands given an unknown one: name it, and the ones there are (CLI11 says only that a
    // subcommand is required).
    const auto subs = app.get_subcommands([](const CLI::App*) { return true; });
    if (!subs.empty() && argc > 1 && argv[1][0] != '-' && std::none_of(subs.begin(), subs.end(), [&](const CLI::App* c) { return c->check_name(argv[1]); })) {
      std::string names;
      for (const CLI::App* c : subs) names += (names.empty() ? "" : ", ") + c->get_name();
      std::fprintf(stderr, "%s: unknown subcommand '%s' (the subcommands are %s; see --help)\n", app.get_name().c_str(),
                   one_line(argv[1], 40).c_str(), names.c_str());
      exit_code = kExitUsage;
      return false;
    }
    std::fprintf(stderr, "%s: %s (see --help)\n", app.get_name().c_str(), one_line(e.what()).c_str());
    exit_code = kExitUsage;
    return false;
  }
  return true;
}

void add_list_backends(CLI::App& app, std::function<std::string(bool json)> describe) {
  CLI::Option* json = app.get_option_no_throw("--json");
  if (!json) json = app.add_flag("--json", "with --list-backends: print them as JSON");
  app.add_flag_callback(
      "--list-backends",
      [json, describe] {
        std::fputs(describe(json->count() > 0).c_str(), stdout);
        throw CLI::Success();
      },
      "print the backends (name, GPU or not, built, vectors per iteration, default iteration limit) and exit; "
      "--json: as JSON");
}

namespace {

// The smallest number of one significant digit that is >= x > 0, as printed by "%.0e" (1.19e-09 -> "2e-09"), so that
// advice names a value that is accepted.
std::string one_digit_at_least(double x) {
  char buf[32];
  for (int digits = 0; digits < 3; ++digits) {  // "%.0e" rounds to nearest: step up until the printed value holds
    double e = std::pow(10.0, std::floor(std::log10(x)));
    double m = std::ceil(x / e) + digits;
    if (m >= 10) m /= 10, e *= 10;
    std::snprintf(buf, sizeof buf, "%.0e", m * e);
    if (std::strtod(buf, nullptr) >= x) return buf;
  }
  return buf;
}

}  // namespace

void check_tolerance(double tol, const std::string& precision) {
  // A residual's rounding can take it a little below the precision's epsilon, not a hundred times below.
  const double eps = precision == "float" ? double(FLT_EPSILON) : DBL_EPSILON, floor = eps / 100;
  char buf[160];
  if (!(tol < 1)) {
    std::snprintf(buf, sizeof buf, "--tol %g: a relative residual tolerance must be below 1 (at 1 the start is already an answer)", tol);
    throw UsageError(buf);
  }
  if (tol < floor) {
    std::snprintf(buf, sizeof buf, "--tol %g is below what %s can reach (its rounding is %.2g): use --tol %s or more%s", tol,
                  precision.c_str(), eps, one_digit_at_least(floor).c_str(),
                  precision == "float" ? ", or --precision double" : "");
    throw UsageError(buf);
  }
}

CLI::Validator integer_in(long long lo, long long hi) {
  return CLI::Validator(
      [lo, hi](std::string& s) -> std::string {
        long long v = 0;
        try {
          size_t pos = 0;
          v = std::stoll(s, &pos);
          if (pos != s.size()) return "'" + one_line(s, 40) + "' is not an integer";
        } catch (const std::out_of_range&) {
          return "'" + one_line(s, 40) + "' is out of range: an integer from " + std::to_string(lo) + " to " + std::to_string(hi);
        } catch (...) {
          return "'" + one_line(s, 40) + "' is not an integer";
        }
        if (v < lo || v > hi)
          return "must be an integer from " + std::to_string(lo) + " to " + std::to_string(hi) + ", got " + s;
        return {};
      },
      "INT in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
}

namespace {

// A validator for a floating-point option whose value must satisfy `ok`; `want` says what it must be.
CLI::Validator real_number(bool (*ok)(double), const char* want, const char* name) {
  return CLI::Validator(
      [ok, want](std::string& s) -> std::string {
        double v = 0;
        try {
          size_t pos = 0;
          v = std::stod(s, &pos);
          if (pos != s.size()) return "'" + one_line(s, 40) + "' is not a number";
        } catch (...) {
          return "'" + one_line(s, 40) + "' is not a number";
        }
        if (!ok(v)) return std::string("must be ") + want + ", got " + one_line(s, 40);
        return {};
      },
      name);
}

}  // namespace

CLI::Validator positive_finite() {
  return real_number([](double v) { return std::isfinite(v) && v > 0; }, "a finite number > 0", "POSITIVE");
}

void add_min_time_option(CLI::App* app, double& seconds) {
  app->add_option("--min-time", seconds,
                  "time a short solve as the median of many in this process: where one solve takes less than S "
                  "seconds, it was a warm-up, and the solve is repeated from the same start until the repetitions "
                  "sum to S; the record's times are the median repetition's, its \"repetitions\" section has them all "
                  "(0: one solve)")
      ->check(real_number([](double v) { return v >= 0 && v <= 3600; }, "a number of seconds from 0 to 3600", "S"))
      ->capture_default_str();
}

CLI::Validator fraction_below_one() {
  return real_number([](double v) { return v >= 0 && v < 1; }, "a number from 0 to below 1", "[0, 1)");
}

void check_threads(int threads) {
  const long cpus = sysconf(_SC_NPROCESSORS_ONLN);
  const long most = 16 * std::max(1L, cpus);
  if (threads > most)
    throw UsageError("--threads " + std::to_string(threads) + " is more than 16 per CPU of this machine (" +
                     std::to_string(cpus) + " online): at most " + std::to_string(most));
}

CLI::Validator byte_size() {
  return CLI::Validator(
      [](std::string& s) -> std::string {
        try {
          parse_bytes(s);
        } catch (const UsageError& e) {
          return e.what();
        }
        return {};
      },
      "BYTES");
}

namespace {

// One line on stderr. Of several MPI ranks, an error they agreed on is reported by rank 0 alone; an error of one
// rank is reported with its rank and ends every rank, as the others may be waiting for it in a collective.
int report(const std::string& program, const std::exception& e, const char* kind, int status) {
  const bool agreed = dynamic_cast<const AgreedError*>(&e) != nullptr;
  const std::string line = one_line(e.what(), 4096);  // whatever a message quotes from a file, safe for a terminal
  if (comm::size() > 1 && !agreed) {
    std::fprintf(stderr, "%s: rank %d of %d: %s%s\n", program.c_str(), comm::rank(), comm::size(), kind, line.c_str());
    std::fflush(stderr);
    comm::abort(status);
  }
  if (comm::root()) std::fprintf(stderr, "%s: %s%s\n", program.c_str(), kind, line.c_str());
  return status;
}

}  // namespace

// The environment settings the programs read, checked as their flags are: OpenMP's thread count (libgomp takes
// 100000 and crashes at the first parallel region; 5000 makes a small solve take seconds) and the huge-page switch.
void check_environment() {
  if (const char* v = std::getenv("OMP_NUM_THREADS")) {  // set but empty is refused too (libgomp warns, goes on)
    const std::string s(v);
    size_t at = 0;
    while (at <= s.size()) {  // OpenMP allows a list, one count per nesting level
      const size_t comma = std::min(s.find(',', at), s.size());
      const std::string part = s.substr(at, comma - at);
      char* end = nullptr;
      const long n = part.empty() ? 0 : std::strtol(part.c_str(), &end, 10);
      if (part.empty() || *end != '\0' || n < 1 || n > 4096)
        throw UsageError("OMP_NUM_THREADS=" + one_line(s, 40) + ": each count must be a whole number of threads from "
                         "1 to 4096 (as --threads)");
      at = comma + 1;
    }
  }
  if (const char* v = std::getenv("HPCGI_HUGE_PAGES"); v && *v && std::string(v) != "0" && std::string(v) != "1")
    throw UsageError("HPCGI_HUGE_PAGES=" + one_line(v, 40) + ": 0 (4 KiB pages) or 1 (huge pages, the default)");
}

int run_main(const std::string& program, const std::function<int()>& body) {
  try {
    check_environment();
    return body();
  } catch (const UsageError& e) {
    return report(program, e, "", kExitUsage);
  } catch (const NumericalError& e) {
    return report(program, e, "numerical failure: ", kExitNumerical);
  } catch (const NotConvergedError& e) {
    return report(program, e, "not converged: ", kExitNotConverged);
  } catch (const DisagreedError& e) {
    return report(program, e, "disagreed with its float64 check: ", kExitDisagreed);
  } catch (const std::exception& e) {
    return report(program, e, "error: ", kExitRuntime);
  }
}

}  // namespace hpcgi
