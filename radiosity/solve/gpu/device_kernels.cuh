// What the GPU backends' kernels add to the Kernels contract: their stream, the clock of CUDA events that splits a
// run's time (config.hpp's SolveResult: upload_s, transfer_s, device_compute_s, host_compute_s, transfer_bytes), and the GPU's
// description. solve.cpp's driver runs them like every other backend.
#pragma once
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "radiosity/solve/gpu/device_common.cuh"
#include "radiosity/solve/contract/kernels.hpp"
#include "radiosity/solve/config/config.hpp"

namespace radiosity::gpu {

// A backend's kernels with the stream they run on and the clock that times them. Members of the base are built
// first and destroyed last, so the stream outlives every array and event of the derived backend.
template <class T>
class DeviceKernels : public Kernels<T> {
 public:
  virtual std::map<std::string, std::string> info() const { return gpu_info(); }
  void settled() override { marks_.push_back(clock_.totals()); }  // totals() waits for the stream
  // The setup's upload, and the rest between the marks after the setup and after the method.
  void account(SolveResult& res) const override {
    if (marks_.size() < 2) return;
    const DeviceTimes &setup = marks_.front(), &all = marks_.back();
    res.upload_s = setup.upload_s;
    res.transfer_s = all.transfer_s - setup.transfer_s;
    res.device_compute_s = all.compute_s - setup.compute_s;
    res.host_compute_s = all.host_compute_s - setup.host_compute_s;
    res.transfer_bytes = all.transfer_bytes - setup.transfer_bytes;
    res.backend_info = info();
  }

 protected:
  Stream stream_;
  DeviceClock clock_{stream_.get()};

 private:
  std::vector<DeviceTimes> marks_;
};

// "backend NAME (N patches, PRECISION)": who asks, in the refusals of require_gpu and require_device_memory.
inline std::string who(const std::string& backend, const System& sys, const SolveConfig& cfg) {
  return "backend " + backend + " (" + std::to_string(sys.n) + " patches, " + to_string(cfg.precision) + ")";
}

}  // namespace radiosity::gpu
