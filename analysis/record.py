"""Run records written from Python (the peers of `make bench`), in the schema of common/record.hpp: one JSON object
per line with schema, app, params, result, times_s, perf, backend_info and provenance, appended by one write()
under an exclusive flock and cut back if the write fails, so a reader never sees half a line."""
import fcntl
import json
import os
import platform
import socket
import subprocess
import time
from pathlib import Path

SCHEMA = "hpcgi-record/1"
ROOT = Path(__file__).resolve().parent.parent
# The environment that decides threads and placement, and the harness's case identifiers (as record.cpp keeps).
ENV_KEYS = ("OMP_NUM_THREADS", "OMP_PROC_BIND", "OMP_PLACES", "OPENBLAS_NUM_THREADS", "SLURM_JOB_ID",
            "SLURM_ARRAY_JOB_ID", "SLURM_ARRAY_TASK_ID", "SLURM_JOB_PARTITION", "SLURM_CLUSTER_NAME",
            "SLURM_NTASKS", "SLURM_JOB_NODELIST", "HPCGI_EXPERIMENT", "HPCGI_PRESET", "HPCGI_CASE", "HPCGI_REPEAT",
            "HPCGI_MACHINE")


def _git(*args):
    try:
        return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None


def _cpu_model():
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def provenance(libraries=None):
    """What ran and where: git commit and dirty flag, Python and library versions (`libraries`: name -> version
    text, e.g. numpy's and its BLAS), host, CPU, threads, the environment of ENV_KEYS, UTC time."""
    head = _git("rev-parse", "HEAD")
    dirty = _git("diff", "--quiet", "HEAD", "--")
    p = {
        "git_commit": head.stdout.strip() if head and head.returncode == 0 else "unknown",
        "git_dirty": bool(dirty is None or dirty.returncode != 0),
        "compiler": f"Python {platform.python_version()} ({platform.python_implementation()})",
        "libraries": dict(libraries or {}),
        "host": socket.gethostname(),
        "os": f"{platform.system()} {platform.release()} {platform.machine()}",
        "cpu_model": _cpu_model(),
        "cpus_online": os.cpu_count(),
        "utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }
    env = {k: os.environ[k] for k in ENV_KEYS if os.environ.get(k)}
    if env:
        p["env"] = env
    return p


def make(app, libraries=None):
    """A new record with schema, app and provenance filled in."""
    return {"schema": SCHEMA, "app": app, "provenance": provenance(libraries)}


def append(path, rec):
    """Appends rec as one line to path (parent folders are created), atomically as common/record.cpp does."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    line = (json.dumps(rec, separators=(",", ":")) + "\n").encode()
    fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_CLOEXEC, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        old = os.fstat(fd).st_size
        try:
            if os.write(fd, line) != len(line):
                raise OSError(f"short write to {path} (disk full?)")
            os.fsync(fd)
        except OSError:
            os.ftruncate(fd, old)
            raise
    finally:
        os.close(fd)  # releases the lock
