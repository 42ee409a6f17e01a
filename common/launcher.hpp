// How a program was started: under an MPI launcher (mpirun, mpiexec, srun with PMI) or by hand. Both programs ask
// before they initialise MPI: the launcher's environment is all there is to go on then.
#pragma once
#include <cstdlib>

namespace hpcgi {

// The world size an MPI launcher announced in the environment (OpenMPI's mpirun, PMI-1 and PMIx), or 0 when the
// program was not started by one. Slurm's srun --mpi=pmix (22.05) sets PMIX_RANK but no PMIX_SIZE: there the size
// is the step's task count.
inline int launcher_world_size() {
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE"}) {
    const char* s = std::getenv(v);
    if (s && std::atoi(s) > 0) return std::atoi(s);
  }
  const char* step_tasks = std::getenv("SLURM_STEP_NUM_TASKS");
  if (std::getenv("PMIX_RANK") && step_tasks && std::atoi(step_tasks) > 0) return std::atoi(step_tasks);
  return 0;
}

// Started as one of several ranks: a backend that runs as one process must refuse, or every rank would do the whole
// run and write the same outputs.
inline bool launched_by_mpirun_with_many_ranks() { return launcher_world_size() > 1; }

}  // namespace hpcgi
