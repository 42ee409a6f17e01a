# Experiment and preset names, sourced by slurm/run-case, run-local, submit, bench and missing: a name is never a
# path (`../quick/formfactors` would put records outside the machine's folder). A name is letters, digits, '-' and '_'
# (slurm/audit and gpukit/archive_check.py hold the same rule), and it must name a case list:
# slurm/cases/PRESET/EXPERIMENT.txt. A bad one ends the script: one line on stderr, exit 2.
NAME_RE='^[A-Za-z0-9][A-Za-z0-9_-]{0,63}$'

check_preset() {  # check_preset PROGRAM PRESET
  [[ $2 =~ $NAME_RE ]] || { echo "$1: PRESET=${2@Q} is no preset name (letters, digits, '-' and '_')" >&2; exit 2; }
  [ -d "slurm/cases/$2" ] || { echo "$1: no preset $2 (no folder slurm/cases/$2)" >&2; exit 2; }
}

check_experiment() {  # check_experiment PROGRAM PRESET EXPERIMENT
  [[ $3 =~ $NAME_RE ]] || { echo "$1: ${3@Q} is no experiment name (letters, digits, '-' and '_')" >&2; exit 2; }
  [ -f "slurm/cases/$2/$3.txt" ] || { echo "$1: no case list slurm/cases/$2/$3.txt" >&2; exit 2; }
}
