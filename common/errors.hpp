// Exit statuses shared by every program of the project, and the exceptions that carry them.
#pragma once
#include <stdexcept>
#include <string>

namespace hpcgi {

enum ExitStatus : int {
  kExitOk = 0,
  kExitRuntime = 1,    // I/O failure, device error, anything the user did not cause by the arguments
  kExitUsage = 2,      // bad arguments or bad input: a one-line message, nothing written
  kExitNumerical = 3,  // the numbers went wrong: NaN/Inf, breakdown, divergence
};

// Bad arguments or bad input data. main() prints "<program>: <what>" and exits with status 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A solver that cannot continue (NaN, Inf, breakdown, divergence). Exit status 3.
struct NumericalError : std::runtime_error {
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

}  // namespace hpcgi
