// The driver of the GPU backends: the same shared methods (jacobi.cpp, bicgstab.cpp) on a backend's kernels,
// as run_method in solve.cpp does for the CPU backends, plus the split of the time that only a device backend has
// (solve.hpp: upload_s, transfer_s, device_compute_s, host_compute_s, transfer_bytes) and the GPU's description.
#pragma once
#include <map>
#include <memory>
#include <string>

#include "common/timer.hpp"
#include "radiosity/solve/device_common.cuh"
#include "radiosity/solve/methods.hpp"
#include "radiosity/solve/solve.hpp"

namespace radiosity::gpu {

// A backend's kernels with the stream they run on and the clock that times them. Members of the base are built
// first and destroyed last, so the stream outlives every array and event of the derived backend.
template <class T>
class DeviceKernels : public Kernels<T> {
 public:
  DeviceTimes times() { return clock_.totals(); }
  virtual std::map<std::string, std::string> info() const { return gpu_info(); }

 protected:
  Stream stream_;
  DeviceClock clock_{stream_.get()};
};

template <class T>
using DeviceFactory = std::unique_ptr<DeviceKernels<T>> (*)(const System& sys, const SolveConfig& cfg, int vectors);

template <class T>
SolveResult run_device(DeviceFactory<T> make, const System& sys, const SolveConfig& cfg,
                       const IterationCallback& callback) {
  SolveResult res;
  const bool jac = cfg.method == "jacobi";
  hpcgi::Timer t;
  const std::unique_ptr<DeviceKernels<T>> k = make(sys, cfg, jac ? kJacobiVectors : kBicgstabVectors);
  k->upload(0, sys.initial);
  const DeviceTimes setup = k->times();  // waits until F and B0 are on the device
  res.setup_s = t.seconds();

  t.reset();
  const Rgb scale = residual_scale(sys);
  const MethodRun run = jac ? jacobi<T>(*k, scale, cfg, callback) : bicgstab<T>(*k, scale, cfg, callback);
  const DeviceTimes all = k->times();  // waits for the last kernel before the clock stops
  res.solve_s = t.seconds() - run.callback_s;

  t.reset();
  k->download(run.answer, res.B);
  res.rel_residual = relative_residual(sys, res.B);
  res.check_s = t.seconds();
  res.iterations = run.iterations;
  res.status = run.status;
  res.detail = run.detail;
  res.matrix_passes = run.matrix_passes;
  res.matrix_bytes = k->matrix_bytes();
  res.threads = k->threads();
  res.upload_s = setup.upload_s;
  res.transfer_s = all.transfer_s - setup.transfer_s;
  res.device_compute_s = all.compute_s - setup.compute_s;
  res.host_compute_s = all.host_compute_s - setup.host_compute_s;
  res.transfer_bytes = all.transfer_bytes - setup.transfer_bytes;
  res.backend_info = k->info();
  return res;
}

template <DeviceFactory<float> MakeFloat, DeviceFactory<double> MakeDouble>
SolveResult run_device_kernels(const System& sys, const SolveConfig& cfg, const IterationCallback& callback) {
  return cfg.precision == "double" ? run_device<double>(MakeDouble, sys, cfg, callback)
                                   : run_device<float>(MakeFloat, sys, cfg, callback);
}

// "backend NAME (N patches, PRECISION)": who asks, in the refusals of require_gpu and require_device_memory.
inline std::string who(const std::string& backend, const System& sys, const SolveConfig& cfg) {
  return "backend " + backend + " (" + std::to_string(sys.n) + " patches, " + cfg.precision + ")";
}

}  // namespace radiosity::gpu
