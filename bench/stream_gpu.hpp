// The GPU half of bin/stream (--device gpu): the same two sweeps as the CPU's, a triad a = b + s·c and a read-only
// sum of a, over arrays of doubles in the GPU's memory, each timed by CUDA events. Defined in stream_gpu.cu where
// the build has CUDA; without it, bin/stream refuses --device gpu with one line.
#pragma once
#include <map>
#include <string>
#include <vector>

namespace hpcgi {

struct GpuSweeps {
  std::vector<double> triad_s, read_s;      // seconds of each trial
  double sum = 0;                           // the last read sweep's sum (7 n when the triad was right)
  bool all_seven = false;                   // every element of a is 7 after the triads (checked on the host)
  std::map<std::string, std::string> info;  // the GPU (common/cuda_check.cuh gpu_info)
};

// n doubles per array, `trials` sweeps of each kind. Throws UsageError where no GPU is usable or the arrays do not
// fit in its memory.
GpuSweeps gpu_sweeps(long n, int trials);

}  // namespace hpcgi
