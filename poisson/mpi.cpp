// Distributed-memory backend (report §3.1): 1-D row blocks along y, one CpuBlock per rank (OpenMP threads inside
// it when --threads > 1), halo rows exchanged with MPI_Isend/Irecv (--halo nonblocking) or MPI_Send/Recv
// (--halo blocking), dots by MPI_Allreduce. Rows are split as evenly as possible: the first N mod P ranks get one
// more row, and when P > N the last P - N ranks hold none and only take part in the reductions.
// Per iteration, classic: one halo row of p, two reductions; onesweep: two halo rows of r and p (each rank
// recomputes its neighbours' edge rows rather than waiting for them), one reduction of (r·r, r·Ar).
#include <mpi.h>
#include <omp.h>

#include <algorithm>
#include <initializer_list>
#include <string>
#include <type_traits>

#include "common/errors.hpp"
#include "poisson/backends.hpp"
#include "poisson/cpu_block.hpp"

namespace poisson {
namespace {

struct Split {
  long y0, ny;
};
Split split_rows(long n, int ranks, int rank) {
  const long base = n / ranks, rem = n % ranks;
  return {rank * base + std::min<long>(rank, rem), base + (rank < rem ? 1 : 0)};
}

template <class T>
class Mpi final : public OneSweepKernels<T> {
 public:
  explicit Mpi(const Config& cfg)
      : rank_(world_rank()), size_(world_size()), part_(split_rows(cfg.n, size_, rank_)), n_(cfg.n),
        blocking_(cfg.halo == "blocking"), onesweep_(cfg.variant == "onesweep"), blk_(cfg.n, part_.y0, part_.ny) {
    const int active = static_cast<int>(std::min<long>(size_, n_));  // ranks 0..active-1 hold rows
    up_ = (rank_ > 0 && rank_ < active) ? rank_ - 1 : MPI_PROC_NULL;
    down_ = (rank_ + 1 < active) ? rank_ + 1 : MPI_PROC_NULL;
    min_rows_ = n_ / active;
  }

  double init() override { return sum(blk_.init()); }
  double calc_w() override {
    exchange({blk_.p()}, 1);
    return sum(blk_.calc_w());
  }
  double calc_ur(double alpha) override { return sum(blk_.calc_ur(alpha)); }
  void calc_p(double beta) override { blk_.calc_p(beta); }
  double r_Ar() override {
    exchange({blk_.r()}, 1);
    return sum(blk_.r_Ar());
  }
  SweepDots sweep(double alpha, double beta) override {
    exchange({blk_.r(), blk_.p()}, 2);
    const SweepDots local = blk_.sweep(alpha, beta);
    double in[2] = {local.rr, local.rAr}, out[2] = {0, 0};
    MPI_Allreduce(in, out, 2, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    return {out[0], out[1]};
  }
  double true_residual2() override {
    exchange({blk_.x()}, 1);
    return sum(blk_.true_residual2());
  }
  double error_inf() override {
    double local = blk_.error_inf(), global = 0;
    MPI_Allreduce(&local, &global, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    return global;
  }
  std::vector<double> solution() override {
    std::vector<double> mine(part_.ny * n_);
    blk_.copy_x(mine.data());
    std::vector<int> counts(size_), displs(size_);
    for (int r = 0; r < size_; ++r) {
      Split s = split_rows(n_, size_, r);
      counts[r] = static_cast<int>(s.ny * n_);
      displs[r] = static_cast<int>(s.y0 * n_);
    }
    std::vector<double> all(rank_ == 0 ? n_ * n_ : 0);
    MPI_Gatherv(mine.data(), static_cast<int>(mine.size()), MPI_DOUBLE, all.data(), counts.data(), displs.data(),
                MPI_DOUBLE, 0, MPI_COMM_WORLD);
    return all;
  }
  int vectors_per_iteration() const override { return onesweep_ ? 6 : 11; }  // as openmp, plus the halo rows
  bool is_root() const override { return rank_ == 0; }
  std::map<std::string, std::string> info() const override {
    char lib[MPI_MAX_LIBRARY_VERSION_STRING];
    int len = 0;
    MPI_Get_library_version(lib, &len);
    std::string l(lib, len);
    l = l.substr(0, l.find_first_of(",\n"));
    return {{"ranks", std::to_string(size_)},
            {"threads", std::to_string(omp_get_max_threads())},
            {"halo", blocking_ ? "blocking" : "nonblocking"},
            {"mpi_library", l}};
  }

 private:
  static int world_rank() {
    int r = 0;
    MPI_Comm_rank(MPI_COMM_WORLD, &r);
    return r;
  }
  static int world_size() {
    int s = 1;
    MPI_Comm_size(MPI_COMM_WORLD, &s);
    return s;
  }
  static MPI_Datatype type() { return std::is_same_v<T, double> ? MPI_DOUBLE : MPI_FLOAT; }
  static double sum(double local) {
    double global = 0;
    MPI_Allreduce(&local, &global, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    return global;
  }

  // Fills `depth` (1 or 2) ghost rows on each side of every vector in vs with the neighbours' edge rows (whole
  // padded rows: the ghost columns are zero). Two rows go in one message when every rank holds at least two;
  // otherwise in two rounds of one row, the second passing on a row received in the first (a rank with one row
  // forwards its neighbour's), so any N and P work.
  void exchange(std::initializer_list<T*> vs, int depth) {
    if (part_.ny == 0) return;
    const int rows = depth == 2 && min_rows_ >= 2 ? 2 : 1;
    for (int k = 0; k < depth; k += rows)  // round k: rows k.. up, rows ny-k-rows.. down
      for (T* v : vs) exchange_rows(v, k, rows);
  }

  // Sends `rows` rows starting at row k up and ending at row ny-1-k down; receives the matching ghost rows.
  void exchange_rows(T* v, int k, int rows) {
    const int count = static_cast<int>(rows * blk_.stride());
    T* send_up = blk_.row(v, k);
    T* send_down = blk_.row(v, part_.ny - k - rows);
    T* recv_up = blk_.row(v, -k - rows);
    T* recv_down = blk_.row(v, part_.ny + k);
    if (!blocking_) {
      MPI_Request req[4];
      MPI_Irecv(recv_up, count, type(), up_, 0, MPI_COMM_WORLD, &req[0]);
      MPI_Irecv(recv_down, count, type(), down_, 1, MPI_COMM_WORLD, &req[1]);
      MPI_Isend(send_up, count, type(), up_, 1, MPI_COMM_WORLD, &req[2]);
      MPI_Isend(send_down, count, type(), down_, 0, MPI_COMM_WORLD, &req[3]);
      MPI_Waitall(4, req, MPI_STATUSES_IGNORE);
      return;
    }
    // Blocking: even ranks send first, odd ranks receive first, so no pair waits on each other.
    if (rank_ % 2 == 0) {
      MPI_Send(send_down, count, type(), down_, 0, MPI_COMM_WORLD);
      MPI_Recv(recv_down, count, type(), down_, 1, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
      MPI_Send(send_up, count, type(), up_, 1, MPI_COMM_WORLD);
      MPI_Recv(recv_up, count, type(), up_, 0, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    } else {
      MPI_Recv(recv_up, count, type(), up_, 0, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
      MPI_Send(send_up, count, type(), up_, 1, MPI_COMM_WORLD);
      MPI_Recv(recv_down, count, type(), down_, 1, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
      MPI_Send(send_down, count, type(), down_, 0, MPI_COMM_WORLD);
    }
  }

  int rank_, size_;
  Split part_;
  long n_;
  bool blocking_, onesweep_;
  CpuBlock<T> blk_;
  int up_ = MPI_PROC_NULL, down_ = MPI_PROC_NULL;
  long min_rows_ = 1;  // the fewest rows any rank holding rows has
};

}  // namespace

template <class T>
std::unique_ptr<Kernels<T>> make_mpi(const Config& cfg) {
  int initialized = 0;
  MPI_Initialized(&initialized);
  if (!initialized) throw hpcgi::UsageError("backend mpi: MPI is not initialized");
  return std::make_unique<Mpi<T>>(cfg);
}
template std::unique_ptr<Kernels<float>> make_mpi(const Config&);
template std::unique_ptr<Kernels<double>> make_mpi(const Config&);

}  // namespace poisson
