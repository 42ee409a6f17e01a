// Wall-clock timing for the host side of a run (device work is synchronised by the backend before it is read).
#pragma once
#include <chrono>

namespace hpcgi {

class Timer {
 public:
  Timer() : start_(Clock::now()) {}
  void reset() { start_ = Clock::now(); }
  double seconds() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }

 private:
  using Clock = std::chrono::steady_clock;
  Clock::time_point start_;
};

}  // namespace hpcgi
