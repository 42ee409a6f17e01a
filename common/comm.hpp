// The few collective operations the radiosity program needs, behind one small interface (TeaLeaf's MPI shim): in a
// build with MPI they are MPI's, on MPI_COMM_WORLD; in a build without it, or before MPI is initialised, they are
// what they mean for one process (a sum of one value is that value). The solvers' own communication (the
// vector gathers) is MPI code in radiosity/solve/mpi/mpi.cpp; what is here serves the commands around it: agreeing on
// a refusal, summing counts for the record, gathering each rank's numbers.
#pragma once
#include <cstdint>
#include <exception>
#include <optional>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "common/errors.hpp"

namespace hpcgi::comm {

// Whether this binary was built with MPI.
bool built();

// MPI_Init_thread (MPI_THREAD_FUNNELED: only the thread that called it talks to MPI, OpenMP threads compute) when
// `want`, MPI_Finalize when it goes. A program holds one for its whole run.
class Session {
 public:
  explicit Session(bool want);
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

 private:
  bool on_ = false;
};

bool active();  // MPI is initialised (and not finalised)
// This process's rank and the number of ranks; 0 and 1 without MPI. Kept after MPI_Finalize, so that an error
// reported while a Session unwinds still knows who reports it.
int rank();
int size();
inline bool root() { return rank() == 0; }

void barrier();
void sum(double* v, int count);    // in place: every rank gets the sums over ranks
void sum(uint64_t* v, int count);
double max(double v);
double min(double v);
std::vector<double> gather(double v);  // every rank's v, in rank order, on every rank
std::string library();                 // "Open MPI v4.1.4", or "none"
// The host of each rank (MPI_Get_processor_name), in rank order; gathered once when the Session starts, so that
// asking is not collective. Empty without MPI.
const std::vector<std::string>& hosts();
[[noreturn]] void abort(int status);   // MPI_Abort: ends every rank

// Collective: every rank says how its part went (status 0, or an exit status of errors.hpp with its message). If
// any rank failed, every rank throws Agreed<...> of that status with the message of the lowest failed rank, so
// that the ranks leave together, rank 0 reports once, and none is left waiting in a collective for ever.
void agree(int status, const std::string& message);

// The exit status an exception stands for (errors.hpp) and its message.
std::pair<int, std::string> classify(std::exception_ptr e);

// Runs f on every rank and agrees on how it went (agree): returns f's value where every rank succeeded. Without
// MPI it only runs f. f must not itself call collective operations that a failed rank would skip.
template <class F>
auto agreed(F&& f) -> decltype(f()) {
  using R = decltype(f());
  if (!active()) return f();
  int status = 0;
  std::string message;
  if constexpr (std::is_void_v<R>) {
    try {
      f();
    } catch (...) {
      std::tie(status, message) = classify(std::current_exception());
    }
    agree(status, message);
  } else {
    std::optional<R> r;
    try {
      r.emplace(f());
    } catch (...) {
      std::tie(status, message) = classify(std::current_exception());
    }
    agree(status, message);
    return std::move(*r);
  }
}

}  // namespace hpcgi::comm
