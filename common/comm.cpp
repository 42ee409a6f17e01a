#include "common/comm.hpp"

#ifdef HAVE_MPI
#include <mpi.h>
#endif

#include <algorithm>
#include <climits>
#include <cstdlib>
#include <exception>
#include <stdexcept>

namespace hpcgi::comm {

std::pair<int, std::string> classify(std::exception_ptr e) {
  try {
    std::rethrow_exception(e);
  } catch (const UsageError& x) {
    return {kExitUsage, x.what()};
  } catch (const NumericalError& x) {
    return {kExitNumerical, x.what()};
  } catch (const std::exception& x) {
    return {kExitRuntime, x.what()};
  } catch (...) {
    return {kExitRuntime, "unknown error"};
  }
}

namespace {
[[noreturn]] void throw_agreed(int status, const std::string& message) {
  if (status == kExitUsage) throw Agreed<UsageError>(message);
  if (status == kExitNumerical) throw Agreed<NumericalError>(message);
  throw Agreed<std::runtime_error>(message);
}
}  // namespace

#ifdef HAVE_MPI

namespace {
int g_rank = 0, g_size = 1;  // set by Session, kept after MPI_Finalize
std::vector<std::string> g_hosts;  // every rank's host, gathered by Session

std::vector<std::string> gather_hosts() {
  char name[MPI_MAX_PROCESSOR_NAME] = {};
  int len = 0;
  MPI_Get_processor_name(name, &len);
  std::vector<char> all(size_t(g_size) * MPI_MAX_PROCESSOR_NAME);
  MPI_Allgather(name, MPI_MAX_PROCESSOR_NAME, MPI_CHAR, all.data(), MPI_MAX_PROCESSOR_NAME, MPI_CHAR, MPI_COMM_WORLD);
  std::vector<std::string> hosts;
  for (int r = 0; r < g_size; ++r) hosts.emplace_back(&all[size_t(r) * MPI_MAX_PROCESSOR_NAME]);
  return hosts;
}
}  // namespace

bool built() { return true; }

Session::Session(bool want) {
  if (!want) return;
  int provided = 0;
  MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
  MPI_Comm_rank(MPI_COMM_WORLD, &g_rank);
  MPI_Comm_size(MPI_COMM_WORLD, &g_size);
  g_hosts = gather_hosts();
  on_ = true;
}

Session::~Session() {
  if (on_) MPI_Finalize();
}

bool active() {
  int init = 0, fin = 0;
  MPI_Initialized(&init);
  MPI_Finalized(&fin);
  return init && !fin;
}

int rank() { return g_rank; }
int size() { return g_size; }
const std::vector<std::string>& hosts() { return g_hosts; }

void barrier() {
  if (active()) MPI_Barrier(MPI_COMM_WORLD);
}

void sum(double* v, int count) {
  if (active()) MPI_Allreduce(MPI_IN_PLACE, v, count, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
}

void sum(uint64_t* v, int count) {
  if (active()) MPI_Allreduce(MPI_IN_PLACE, v, count, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
}

double max(double v) {
  if (active()) MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  return v;
}

double min(double v) {
  if (active()) MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
  return v;
}

std::vector<double> gather(double v) {
  if (!active()) return {v};
  std::vector<double> all(static_cast<size_t>(g_size));
  MPI_Allgather(&v, 1, MPI_DOUBLE, all.data(), 1, MPI_DOUBLE, MPI_COMM_WORLD);
  return all;
}

std::string library() {
  char lib[MPI_MAX_LIBRARY_VERSION_STRING];
  int len = 0;
  MPI_Get_library_version(lib, &len);
  std::string l(lib, size_t(len));
  return l.substr(0, l.find_first_of(",\n"));
}

void abort(int status) {
  if (active()) MPI_Abort(MPI_COMM_WORLD, status);
  std::exit(status);
}

void agree(int status, const std::string& message) {
  if (!active()) {
    if (status != 0) throw_agreed(status, message);
    return;
  }
  // The lowest failed rank, then its status and message broadcast from it.
  int first = status != 0 ? g_rank : INT_MAX;
  MPI_Allreduce(MPI_IN_PLACE, &first, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  if (first == INT_MAX) return;
  int head[2] = {status, int(message.size())};
  MPI_Bcast(head, 2, MPI_INT, first, MPI_COMM_WORLD);
  std::string text = g_rank == first ? message : std::string(size_t(head[1]), ' ');
  MPI_Bcast(text.data(), head[1], MPI_CHAR, first, MPI_COMM_WORLD);
  throw_agreed(head[0], text);
}

#else  // one process: what each operation means for a world of one rank

bool built() { return false; }
Session::Session(bool) {}
Session::~Session() = default;
bool active() { return false; }
int rank() { return 0; }
int size() { return 1; }
void barrier() {}
void sum(double*, int) {}
void sum(uint64_t*, int) {}
double max(double v) { return v; }
double min(double v) { return v; }
std::vector<double> gather(double v) { return {v}; }
std::string library() { return "none"; }
const std::vector<std::string>& hosts() {
  static const std::vector<std::string> none;
  return none;
}
void abort(int status) { std::exit(status); }
void agree(int status, const std::string& message) {
  if (status != 0) throw_agreed(status, message);
}

#endif

}  // namespace hpcgi::comm
