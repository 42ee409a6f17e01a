#!/usr/bin/env bash
# Installs what the project needs on a Debian machine: `make deps` runs it, `make test` runs it when something
# is missing. As root it installs; otherwise it prints exactly what is missing and exits 1.
#   common/deps.sh          install what is missing
#   common/deps.sh --check  exit 0 if nothing is missing, 1 otherwise (prints nothing)
set -euo pipefail
cd "$(dirname "$0")/.."

DEBIAN_PACKAGES=(
  g++ make git python3 python3-venv
  libgtest-dev libbenchmark-dev nlohmann-json3-dev libcli11-dev libpugixml-dev libpng-dev
  openmpi-bin libopenmpi-dev
  slurmctld slurmd slurm-client munge
  clang libclang-rt-dev  # make fuzz: libFuzzer and clang's sanitizers
  python3-petsc4py       # make bench: PETSc (with hypre) as the peer of bin/poisson --precond mg
  libfftw3-double3       # make bench: FFTW's RODFT00, the direct solver (bench/dst_poisson.py) beside --method fmg
  chromium  # tests/integration/test_relight.py: bin/radiosity web's page in headless Chromium
)
VENV=${VENV:-.venv}
PYTHON=${PYTHON:-python3}

missing_packages() {
  local p
  for p in "${DEBIAN_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || echo "$p"
  done
}

venv_ok() {
  [ -x "$VENV/bin/python" ] && [ -f "$VENV/.requirements" ] && cmp -s requirements.txt "$VENV/.requirements"
}

mapfile -t missing < <(missing_packages)
if [ "${1:-}" = "--check" ]; then
  [ ${#missing[@]} -eq 0 ] && venv_ok && exit 0
  exit 1
fi

if [ ${#missing[@]} -gt 0 ]; then
  if [ "$(id -u)" -ne 0 ]; then
    echo "deps: missing Debian packages: ${missing[*]}" >&2
    echo "deps: as root run: apt-get update && apt-get install -y ${missing[*]}" >&2
    exit 1
  fi
  echo "deps: installing Debian packages: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

if ! venv_ok; then
  echo "deps: creating $VENV from requirements.txt (pinned versions)"
  rm -rf "$VENV"
  "$PYTHON" -m venv "$VENV"
  "$VENV/bin/pip" install -q --disable-pip-version-check -r requirements.txt
  cp requirements.txt "$VENV/.requirements"
fi
echo "deps: all present"
