// bin/stream: the memory-bandwidth limit of this machine, measured with the compiler, flags and OpenMP threads of
// the solvers (the limit their bandwidth fractions are taken against). Two sweeps over arrays far larger than
// the caches, after McCalpin's STREAM:
//   triad  a = b + s·c   counted as 24 bytes per element (2 reads, 1 write; STREAM's convention: the line that
//                        a write allocates is not counted, so the true traffic is 32 bytes where stores allocate)
//   read   Σ b           8 bytes per element (a read-only sweep, the pattern of a matrix-vector product; each
//                        thread reads its block as four streams, common/read_sweep.hpp, summed as 64-bit words).
//                        It reads b, which nothing writes after the first touch: until issue 37 it read a, just
//                        written by the triad, so the sweep also paid for writing back the triad's dirty lines as it
//                        evicted them (2-core Intel VM, 2026-12-06, three alternating runs of --threads 2 --trials
//                        10: 34.0-35.8 GB/s reading a, 42.2-47.6 GB/s reading b), and the dense product out-read it.
// Each sweep runs --trials times; the record keeps the best (STREAM's figure) and the median trial. The arrays are
// first touched by the same static schedule as the sweeps, and the results are checked after the timing.
// --device gpu runs the same two sweeps in the GPU's memory (bench/stream_gpu.cu), timed by CUDA events.
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "common/cli.hpp"
#include "common/files.hpp"
#include "common/errors.hpp"
#include "common/memory.hpp"
#include "common/read_sweep.hpp"
#include "common/record.hpp"
#include "bench/stream_gpu.hpp"
#include "common/timer.hpp"

namespace {

struct Args : hpcgi::record::Options {
  long size = 1L << 25;  // elements per array: 256 MiB of doubles, 8 times a 32 MiB last-level cache
  int trials = 20;
  long read_prefetch = 0;  // bytes ahead the read sweep asks for each line (0: none)
  int threads = 0;
  std::string device = "cpu";
};

struct Stats {
  double best = 0, median = 0;  // seconds
};

Stats stats(std::vector<double> t) {
  std::sort(t.begin(), t.end());
  const size_t m = t.size() / 2;
  return {t.front(), t.size() % 2 ? t[m] : 0.5 * (t[m - 1] + t[m])};
}

constexpr double kOne = 1.0;

// The sweeps on the CPU's OpenMP threads: the seconds of each trial, and whether the values were right.
bool cpu_sweeps(const Args& a, std::vector<double>& triad_t, std::vector<double>& read_t) {
  const long n = a.size;
  hpcgi::require_host_memory("bin/stream --size " + std::to_string(n), 3.0 * sizeof(double) * n);
  std::unique_ptr<double[]> av(new double[n]), bv(new double[n]), cv(new double[n]);
  double *x = av.get(), *y = bv.get(), *z = cv.get();
#pragma omp parallel for schedule(static)
  for (long i = 0; i < n; ++i) {
    x[i] = 0.0;
    y[i] = 1.0;
    z[i] = 2.0;
  }
  const double s = 3.0;
  uint64_t sum = 0;
  for (int k = 0; k < a.trials; ++k) {
    hpcgi::Timer t;
#pragma omp parallel for schedule(static)
    for (long i = 0; i < n; ++i) x[i] = y[i] + s * z[i];
    triad_t.push_back(t.seconds());
    t.reset();
    uint64_t acc = 0;
#pragma omp parallel reduction(+ : acc)
    acc += hpcgi::read_share(y, sizeof(double) * size_t(n), omp_get_thread_num(), omp_get_num_threads(),
                             size_t(a.read_prefetch));
    read_t.push_back(t.seconds());
    sum = acc;
  }
  // Every element of a is 1 + 3·2 = 7; the read sweep summed b's n words of 1.0's bits (wrapping).
  uint64_t one;
  std::memcpy(&one, &kOne, sizeof one);
  return sum == uint64_t(n) * one && std::all_of(x, x + n, [](double v) { return v == 7.0; });
}

int run(const Args& a) {
  const long n = a.size;
  const bool gpu = a.device == "gpu";
  std::vector<double> triad_t, read_t;
  bool valid = false;
  std::map<std::string, std::string> info;
  if (gpu) {
#ifdef HAVE_CUDA
    hpcgi::GpuSweeps g = hpcgi::gpu_sweeps(n, a.trials);
    triad_t = g.triad_s;
    read_t = g.read_s;
    valid = g.all_seven && g.sum == 7.0 * static_cast<double>(n);
    info = g.info;
#else
    throw hpcgi::UsageError("--device gpu needs a build with CUDA, and this bin/stream was built without (no nvcc)");
#endif
  } else {
    valid = cpu_sweeps(a, triad_t, read_t);
  }
  if (!valid) throw hpcgi::NumericalError("the sweeps computed wrong values");

  const Stats tr = stats(triad_t), rd = stats(read_t);
  const double triad_bytes = 24.0 * n, read_bytes = 8.0 * n;
  const int threads = gpu ? 1 : omp_get_max_threads();
  nlohmann::json rec = hpcgi::record::make("stream");
  rec["params"] = {{"size", n}, {"array_bytes", 8.0 * n}, {"trials", a.trials}, {"threads", threads},
                   {"precision", "double"}, {"device", a.device}};
  if (!gpu) rec["params"]["read_sweep"] = {{"streams_per_thread", hpcgi::kReadStreams}, {"prefetch_bytes", a.read_prefetch}};
  rec["result"] = {{"valid", valid}};
  rec["times_s"] = {{"triad_best", tr.best}, {"triad_median", tr.median}, {"read_best", rd.best},
                    {"read_median", rd.median}};
  rec["perf"] = {{"triad_bytes", triad_bytes},
                 {"read_bytes", read_bytes},
                 {"triad_GBps", triad_bytes / tr.best / 1e9},
                 {"triad_median_GBps", triad_bytes / tr.median / 1e9},
                 {"read_GBps", read_bytes / rd.best / 1e9},
                 {"read_median_GBps", read_bytes / rd.median / 1e9},
                 {"timer", gpu ? "CUDA events" : "host wall clock"}};
  info["threads"] = std::to_string(threads);
  rec["backend_info"] = info;
  if (!a.quiet) {
    if (gpu)
      std::printf("stream: %ld doubles per array (%.0f MiB) on the GPU %s, best and median of %d trials\n", n,
                  8.0 * n / (1 << 20), info["gpu"].c_str(), a.trials);
    else
      std::printf("stream: %ld doubles per array (%.0f MiB), %d threads, best and median of %d trials\n", n,
                  8.0 * n / (1 << 20), threads, a.trials);
    std::printf("  triad a = b + s*c: %.2f GB/s (median %.2f GB/s)\n", triad_bytes / tr.best / 1e9,
                triad_bytes / tr.median / 1e9);
    std::printf("  read  sum(%s):      %.2f GB/s (median %.2f GB/s)\n", gpu ? "a" : "b", read_bytes / rd.best / 1e9,
                read_bytes / rd.median / 1e9);
  }
  hpcgi::record::emit(rec, a);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  CLI::App app{
      "The memory bandwidth of this machine with the solvers' compiler, flags and OpenMP threads: a STREAM triad\n"
      "(a = b + s*c, 24 bytes per element) and a read-only sweep (sum of b, 8 bytes per element) over arrays far\n"
      "larger than the caches; best and median of --trials sweeps.",
      "stream"};
  app.add_option("--size", a.size, "elements (doubles) per array; 3 arrays")
      ->check(hpcgi::integer_in(1LL << 10, 1LL << 36))->capture_default_str();
  app.add_option("--trials", a.trials, "sweeps of each kind")->check(hpcgi::integer_in(1, 100000))->capture_default_str();
  app.add_option("--read-prefetch", a.read_prefetch,
                 "bytes ahead of each line the read sweep asks for (0: the hardware's prefetch alone)")
      ->check(hpcgi::integer_in(0, 1LL << 20))->capture_default_str();
  app.add_option("--threads", a.threads, "OpenMP threads (default: OMP_NUM_THREADS or all cores)")
      ->check(hpcgi::integer_in(1, 4096));
  app.add_option("--device", a.device, "cpu: the CPU's OpenMP threads; gpu: the GPU's memory (CUDA events)")
      ->check(CLI::IsMember({"cpu", "gpu"}))
      ->capture_default_str();
  hpcgi::add_record_options(&app, a);
  app.footer("\nExamples:\n  OMP_PROC_BIND=close OMP_PLACES=cores bin/stream --threads 2\n  bin/stream --device gpu\n");
  int code = 0;
  if (!hpcgi::parse_cli(app, argc, argv, code)) return code;
  return hpcgi::run_main("stream", [&] {
    hpcgi::files::check_outputs({{a.record_path, "--record", true}}, {});
    hpcgi::check_threads(a.threads);
    if (a.threads > 0) omp_set_num_threads(a.threads);
    return run(a);
  });
}
