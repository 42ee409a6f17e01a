// Distributed-memory backend (report §3.1): 1-D row blocks along y, one CpuBlock per rank (OpenMP threads inside
// it when --threads > 1), halo rows exchanged with MPI_Isend/Irecv (--halo nonblocking) or MPI_Send/Recv
// (--halo blocking), dots by MPI_Allreduce. Rows are split as evenly as possible: the first N mod P ranks get one
// more row, and when P > N the last P - N ranks hold none and only take part in the reductions.
// Per iteration, classic: one halo row of p, two reductions; onesweep: two halo rows of r and p (each rank
// recomputes its neighbours' edge rows rather than waiting for them), one reduction of (r·r, r·Ar).
// Multigrid (--precond mg, mg_cpu.hpp): every level is split in row blocks as long as every rank holding rows
// keeps at least kMgMinRows of it: coarse row J belongs to the rank holding fine row 2J + 1, so a rank's coarse
// block is [y0/2, y1/2) of its fine block [y0, y1). Each distributed level's fused passes (mg_cpu.hpp) exchange
// one halo row of x after the edge rows' first colour and one after the pass, one of the residual's edge rows
// before the edge coarse rows, one of the coarse x before the prolongation; CG's p = z + βp one row of p after
// its edge rows. The first level that would leave some rank fewer rows, and every level below it, is gathered
// to every rank: the restricted rows are made whole by one MPI_Allgatherv, and each rank then runs the rest of
// the V-cycle on the whole (small) grids by itself, the same arithmetic everywhere, and prolongs into its own rows
// of the finer level. (Simpler than gathering to fewer ranks, and correct for any N and P, also P > N.)
#include <mpi.h>
#include <omp.h>

#include <algorithm>
#include <initializer_list>
#include <string>
#include <type_traits>

#include "common/comm.hpp"
#include "common/errors.hpp"
#include "poisson/contract/backends.hpp"
#include "poisson/backends/cpu_block.hpp"
#include "poisson/backends/cpu_pcg.hpp"

namespace poisson {
namespace {

struct Split {
  long y0, ny;
};
Split split_rows(long n, int ranks, int rank) {
  const long base = n / ranks, rem = n % ranks;
  return {rank * base + std::min<long>(rank, rem), base + (rank < rem ? 1 : 0)};
}

constexpr long kMgMinRows = 8;

template <class T>
class Mpi final : public OneSweepKernels<T>, public Preconditioned, public MgComm<T> {
 public:
  explicit Mpi(const Config& cfg)
      : rank_(hpcgi::comm::rank()), size_(hpcgi::comm::size()), part_(split_rows(cfg.n, size_, rank_)), n_(cfg.n),
        blocking_(cfg.halo == Halo::blocking), onesweep_(cfg.variant == Variant::onesweep), fmg_(cfg.method == Method::fmg),
        blk_(cfg.n, part_.y0, part_.ny, fmg_) {
    const int active = static_cast<int>(std::min<long>(size_, n_));  // ranks 0..active-1 hold rows
    up_ = (rank_ > 0 && rank_ < active) ? rank_ - 1 : MPI_PROC_NULL;
    down_ = (rank_ + 1 < active) ? rank_ + 1 : MPI_PROC_NULL;
    min_rows_ = n_ / active;
    if (cfg.multigrid()) make_mg(active);
  }

  // Preconditioned (the hierarchy of the comment at the top).
  double precondition() override { return sum(pcg_->precondition()); }
  double solve_cycle(bool full) override { return sum(pcg_->solve_cycle(full)); }
  void calc_p_z(double beta) override { pcg_->calc_p_z(beta); }
  bool fused_updates() const override { return true; }
  double calc_p_pw(double beta) override {
    return sum(pcg_->calc_p_pw(beta, [this] { exchange({blk_.p()}, 1); }));
  }
  double calc_ur_p(double alpha) override { return sum(pcg_->calc_ur_p(alpha)); }
  std::vector<long> mg_sizes() const override { return mg_level_sizes(n_); }
  std::vector<double> fmg_vectors_per_level() const override {
    return poisson::fmg_vectors_per_level(n_, kFusedLevelKernels);
  }
  double fmg_correction_vectors() const override { return 0; }  // the cycles run on x
  OneSweepKernels<T>* one_sweep() override { return this; }
  Preconditioned* multigrid() override { return this; }
  double apply_dot(const GridFn& x, const GridFn& y) override { return sum(pcg_->apply_dot(x, y, part_.y0)); }
  // MgComm.
  void halo(CpuLevel<T>& lv, T* v) override {
    const long ny = lv.rows.ny;
    if (ny > 0) swap_rows(lv.row(v, 0), lv.row(v, ny - 1), lv.row(v, -1), lv.row(v, ny), static_cast<int>(lv.s));
  }
  void gather_b(CpuLevel<T>& lv) override {
    const auto& [counts, displs] = gathers_.at(lv.rows.n);
    MPI_Allgatherv(MPI_IN_PLACE, 0, type(), lv.row(lv.b, 0), counts.data(), displs.data(), type(), MPI_COMM_WORLD);
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
  // As openmp, plus the halo rows.
  int vectors_per_iteration() const override {
    return fmg_ ? static_cast<int>(mg_solve_vectors_per_cycle(n_) + 0.5)
                : pcg_ ? 8 + mg_fused_vectors_per_cycle(n_) : onesweep_ ? kVectorsOneSweep : kVectorsClassic;
  }
  bool is_root() const override { return rank_ == 0; }
  std::map<std::string, std::string> info() const override {
    return {{"ranks", std::to_string(size_)},
            {"threads", std::to_string(omp_get_max_threads())},
            {"halo", to_string(blocking_ ? Halo::blocking : Halo::nonblocking)},
            {"mpi_library", hpcgi::comm::library()}};
  }

 private:
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
    swap_rows(blk_.row(v, k), blk_.row(v, part_.ny - k - rows), blk_.row(v, -k - rows), blk_.row(v, part_.ny + k),
              static_cast<int>(rows * blk_.stride()));
  }

  // count values from send_up to the rank above and from send_down to the rank below, received into recv_down
  // (from below) and recv_up (from above).
  void swap_rows(T* send_up, T* send_down, T* recv_up, T* recv_down, int count) {
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

  // The rows of every level on every rank (the comment at the top), the gathers of the first whole level, z and
  // the hierarchy.
  void make_mg(int active) {
    const std::vector<long> sizes = mg_level_sizes(n_);
    std::vector<Split> all(size_);
    for (int r = 0; r < size_; ++r) all[r] = split_rows(n_, size_, r);
    std::vector<LevelRows> rows{{n_, part_.y0, part_.ny, false}};
    bool whole = false;
    for (size_t l = 1; l < sizes.size(); ++l) {
      std::vector<Split> next(size_);
      for (int r = 0; r < size_; ++r) next[r] = {all[r].y0 / 2, (all[r].y0 + all[r].ny) / 2 - all[r].y0 / 2};
      if (!whole) {
        for (int r = 0; r < active; ++r) whole = whole || next[r].ny < kMgMinRows;
        if (whole) {  // the first whole level: each rank restricts its rows of next, then one Allgatherv
          const long s = sizes[l] + 2;
          std::vector<int> counts(size_), displs(size_);
          for (int r = 0; r < size_; ++r) {
            counts[r] = static_cast<int>(next[r].ny * s);
            displs[r] = static_cast<int>(next[r].y0 * s);
          }
          gathers_[sizes[l]] = {counts, displs};
        }
      }
      rows.push_back(whole ? LevelRows{sizes[l], 0, sizes[l], true}
                           : LevelRows{sizes[l], next[rank_].y0, next[rank_].ny, false});
      all = next;
    }
    pcg_ = std::make_unique<CpuPcg<T>>(blk_, rows, this, fmg_);
  }

  int rank_, size_;
  Split part_;
  long n_;
  bool blocking_, onesweep_, fmg_;
  CpuBlock<T> blk_;
  int up_ = MPI_PROC_NULL, down_ = MPI_PROC_NULL;
  long min_rows_ = 1;  // the fewest rows any rank holding rows has
  std::unique_ptr<CpuPcg<T>> pcg_;
  std::map<long, std::pair<std::vector<int>, std::vector<int>>> gathers_;  // n of the first whole level -> counts, displs
};

}  // namespace

template <class T>
std::unique_ptr<Kernels<T>> make_mpi(const Config& cfg) {
  // MPI is the program's comm::Session (common/comm.hpp), opened before the backend is made; rank and size are its.
  if (!hpcgi::comm::active()) throw hpcgi::UsageError("backend mpi: MPI is not initialized (no comm::Session)");
  return std::make_unique<Mpi<T>>(cfg);
}
template std::unique_ptr<Kernels<float>> make_mpi(const Config&);
template std::unique_ptr<Kernels<double>> make_mpi(const Config&);

}  // namespace poisson
