// Exit statuses shared by every program of the project, and the exceptions that carry them.
//
// A run's exit status says whether it is an answer. Only 0 is one; for 3, 4 and 5 the run record is still
// written (result.status, result.exit_status and result.exit_reason say what happened), and the harness counts
// such a case as done with that status (slurm/run-case), not as a case to run again.
//
//   0  an answer: converged to the tolerance (or the fixed --steps ran) and, unless --no-verify, agreed with the
//      float64 check
//   1  a runtime failure: I/O, a device error, anything the user did not cause by the arguments (no record)
//   2  bad arguments or bad input: one line on stderr, nothing written
//   3  a numerical failure: NaN/Inf, breakdown, divergence, or stagnation ("no solution: ...": the residual
//      stopped decreasing far above the tolerance)
//   4  not converged: the tolerance was not reached within --max-iter
//   5  disagreed: the run ended, but its answer differs from its float64 check by more than the bound
#pragma once
#include <stdexcept>
#include <string>

namespace hpcgi {

enum ExitStatus : int {
  kExitOk = 0,
  kExitRuntime = 1,       // I/O failure, device error, anything the user did not cause by the arguments
  kExitUsage = 2,         // bad arguments or bad input: a one-line message, nothing written
  kExitNumerical = 3,     // the numbers went wrong: NaN/Inf, breakdown, divergence, stagnation (no solution)
  kExitNotConverged = 4,  // the tolerance was not reached within --max-iter
  kExitDisagreed = 5,     // the answer disagreed with its float64 check
};

// The help text of the table above, for every program's --help; `skip_verify`: the option by which the program
// skips its float64 check, where it has one (a --help lists only what its program accepts).
inline std::string exit_status_help(const char* skip_verify = nullptr) {
  return std::string("Exit status: 0 an answer (converged, or the fixed --steps ran, and agreed with its float64 check") +
         (skip_verify ? std::string(" unless\n") + skip_verify : std::string("")) +
         "); 1 runtime failure (I/O, device); 2 bad arguments or input (nothing written); 3\n"
         "numerical failure (NaN/Inf, breakdown, divergence, 'no solution': the residual stopped decreasing far\n"
         "above the tolerance, or an unphysical answer); 4 not converged within --max-iter; 5 disagreed with its\n"
         "float64 check. With 3, 4 and 5 the record (--record) is still written, with result.exit_status and\n"
         "result.exit_reason.\n";
}

// Bad arguments or bad input data. main() prints "<program>: <what>" and exits with status 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A solver that cannot continue (NaN, Inf, breakdown, divergence, stagnation). Exit status 3.
struct NumericalError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A solve that ran to --max-iter without reaching its tolerance. Exit status 4.
struct NotConvergedError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A solve whose answer disagreed with its float64 check. Exit status 5.
struct DisagreedError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// An error that every rank of an MPI run raised alike, having agreed on it (common/comm.hpp): rank 0 alone reports
// it and every rank exits with its status. Any other error on one rank of several ends the whole run (MPI_Abort),
// since the other ranks would wait for that rank for ever.
struct AgreedError {
  virtual ~AgreedError() = default;
};
template <class E>
struct Agreed : E, AgreedError {
  using E::E;
};

// How a run ended, as its exit status says it: the status and, unless it is 0, one line saying why.
struct Outcome {
  int status = kExitOk;
  std::string reason;
};

// Ends a run that is no answer, after its record was written: throws the exception of o.status (3, 4 or 5), which
// run_main turns into that exit status and one line; agreed: every MPI rank throws it alike. Returns for status 0.
inline void finish(const Outcome& o, bool agreed = false) {
  switch (o.status) {
    case kExitOk: return;
    case kExitNumerical:
      if (agreed) throw Agreed<NumericalError>(o.reason);
      throw NumericalError(o.reason);
    case kExitNotConverged:
      if (agreed) throw Agreed<NotConvergedError>(o.reason);
      throw NotConvergedError(o.reason);
    case kExitDisagreed:
      if (agreed) throw Agreed<DisagreedError>(o.reason);
      throw DisagreedError(o.reason);
    default: throw std::logic_error("finish: exit status " + std::to_string(o.status) + " is no outcome of a run");
  }
}

}  // namespace hpcgi
