"""What the GPU node offers the kit, probed once each before the plan runs: the kit's programs' libraries (cuBLAS 13,
cuSPARSE 12 and its nvJitLink 13 from the node), the driver (libcuda.so.1, loaded as the programs load it), a GPU
the cuda backend runs on, and compute-sanitizer. Each probe returns what it found, or why not, in one line.
Standard library only (it runs on the node)."""
import json
import os
import shutil
import subprocess
import sys

from gpukit import libs
from gpukit.checks import sanitizer_refusal

# What each capability of the plan's steps (plan.needs_of) needs of the node's CUDA libraries.
CAPABILITY_LIBS = {"cublas": ("libcublas.so.13", "libcublasLt.so.13"),
                   "cusparse": ("libcusparse.so.12", "libnvJitLink.so.13")}
CAPABILITY_NAMES = {"cublas": "cuBLAS 13", "cusparse": "cuSPARSE 12"}

# Loads libcuda.so.1 as the programs do (the loader's search: LD_LIBRARY_PATH, then its cache), says from where,
# and asks it its version and its devices. Run in a child with the programs' environment.
DRIVER_PROBE = r"""
import ctypes, json
out = {}
try:
    lib = ctypes.CDLL("libcuda.so.1")
except OSError as e:
    out["error"] = str(e)
else:
    out["path"] = next((l.split()[-1] for l in open("/proc/self/maps") if "libcuda.so" in l), None)
    v, n = ctypes.c_int(0), ctypes.c_int(0)
    try:
        out["version"] = v.value if lib.cuDriverGetVersion(ctypes.byref(v)) == 0 else None
        out["init"] = lib.cuInit(0)
        if out["init"] == 0 and lib.cuDeviceGetCount(ctypes.byref(n)) == 0:
            out["devices"] = n.value
    except AttributeError as e:
        out["error"] = "not a CUDA driver: " + str(e)
print(json.dumps(out))
"""


def cuda_version(v):
    return f"{v // 1000}.{v % 1000 // 10}" if v else "unknown"


def driver(env, cwd):
    """(found: bool, one line): libcuda.so.1 as the programs' environment finds it."""
    try:
        p = subprocess.run([sys.executable, "-B", "-c", DRIVER_PROBE], env=env, cwd=cwd, capture_output=True, text=True,
                           timeout=60)
        d = json.loads(p.stdout.strip().splitlines()[-1])
    except subprocess.TimeoutExpired:
        return False, "libcuda.so.1: the probe did not answer within 60 s"
    except (OSError, ValueError, IndexError) as e:
        return False, f"libcuda.so.1: the probe failed ({type(e).__name__}: {e})"
    if "path" not in d:
        return False, (f"libcuda.so.1 not found (LD_LIBRARY_PATH={env.get('LD_LIBRARY_PATH', '')}, then the "
                       f"loader's cache): {d.get('error', '')}")
    line = f"libcuda.so.1 from {d['path']}, CUDA {cuda_version(d.get('version'))}"
    if d.get("error"):
        return False, f"{line}: {d['error']}"
    if d.get("init") != 0:
        return False, f"{line}: cuInit failed with CUresult {d.get('init')}"
    return True, f"{line}, {d.get('devices')} device(s)"


def resolved(binaries, env):
    """[(library, path or None)] of every library the binaries need, as the loader resolves them in `env`."""
    return [pair for b in binaries for pair in libs.ldd(b, env)]


def missing_libraries(binaries, env):
    """{capability: one line naming exactly what is missing} for the node's CUDA libraries that the `binaries` do
    not find, and [other libraries not found] (the kit itself is then broken)."""
    try:
        found = resolved(binaries, env)
    except (RuntimeError, OSError, subprocess.TimeoutExpired) as e:
        return {}, [f"ldd: {e}"]
    absent = {name for name, where in found if where is None}
    caps = {}
    for cap, sonames in CAPABILITY_LIBS.items():
        gone = [so for so in sonames if so in absent]
        if gone:
            caps[cap] = f"{CAPABILITY_NAMES[cap]}: {', '.join(gone)} not found"
    other = sorted(absent - {so for s in CAPABILITY_LIBS.values() for so in s})
    return caps, [f"{so} not found" for so in other]


def sanitizer_path(environ):
    for c in (shutil.which("compute-sanitizer", path=environ.get("PATH", "")),
              os.path.join(environ.get("CUDA_HOME", "/usr/local/cuda"), "bin", "compute-sanitizer"),
              "/usr/local/cuda/bin/compute-sanitizer", "/usr/local/cuda/compute-sanitizer/compute-sanitizer"):
        if c and os.access(c, os.X_OK):
            return c
    return None


def sanitizer(path, program, env, cwd):
    """(usable: bool, one line): compute-sanitizer's memcheck on a 4 × 4 Poisson solve. Not usable only when it is
    absent, does not answer, or refuses the device (as under gVisor); an error it finds is left to its steps."""
    if path is None:
        return False, "compute-sanitizer not found (PATH, $CUDA_HOME/bin, /usr/local/cuda/bin)"
    argv = [path, "--tool", "memcheck", "--error-exitcode", "9", str(program), "--backend", "cuda", "--n", "4",
            "--quiet"]
    try:
        p = subprocess.run(argv, env=env, cwd=cwd, capture_output=True, text=True, errors="replace", timeout=60,
                           start_new_session=True)
    except subprocess.TimeoutExpired:
        return False, f"{path} did not answer within 60 s on a 4 x 4 Poisson solve"
    except OSError as e:
        return False, f"{path} cannot run: {e}"
    refusal = sanitizer_refusal(p.stdout + p.stderr)
    if refusal:
        return False, f"{path} refuses this GPU ({refusal}), as under gVisor"
    if p.returncode != 0:
        return True, f"{path}: its probe exited {p.returncode}; its steps run and are judged each"
    return True, f"{path}: memcheck runs here"
