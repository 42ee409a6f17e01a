"""python -m bench.dst_poisson --n N --fft scipy|fftw [--threads T] [--record FILE] [--json] [--quiet]: the direct
fast solver of bin/poisson's problem, the peer of `make bench` for --method fmg (issue 37).

The same system as bin/poisson: N × N interior points, h = 1/(N+1), the h²-scaled 5-point matrix (4 on the
diagonal, -1 per neighbour), b = h² f of u = sin²(πx) sin²(πy). Two discrete sine transforms of type I (one per
dimension) diagonalise the matrix, with eigenvalues λ_i + λ_j, λ_k = 2 − 2 cos(π k / (N+1)), so
    u_h = S⁻¹ [(S b) / (λ_i + λ_j)],   S = DST-I in x and y,
the exact discrete solution (to rounding), with no tolerance and no iterations. The transforms:
  scipy  scipy.fft.dstn / idstn, type 1, in place, --threads workers (pocketfft);
  fftw   FFTW 3's RODFT00 (the same DST-I) from Debian's libfftw3-double3, through ctypes (no headers needed): one
         2-D r2r plan (FFTW_ESTIMATE, made in the setup), in place, on --threads threads (libfftw3_threads);
         S⁻¹ = S / (2 (N+1))² per the FFTW manual.
Both are fast where 2 (N+1) has only small prime factors (N + 1 a power of two: 8191, 4095) and slower elsewhere
(N = 8192: 2 · 8193 = 2 · 3 · 2731).

Times: setup (the grid, b, the plan), solve (the two transforms and the division), check (the true residual
‖b − A u_h‖/‖b‖ and the error ‖u − u_h‖∞ against the exact solution, as bin/poisson). Exit status as bin/poisson's
(common/errors.hpp): 0 an answer, 2 bad arguments (one line on stderr) or FFTW missing."""
import argparse
import ctypes
import ctypes.util
import os
import sys
import time

from common import record
from bench.peers import Parser, UsageError, positive

FFTW_RODFT00, FFTW_ESTIMATE = 7, 1 << 6  # fftw3.h: enum fftw_r2r_kind_do_not_use_me, planner flags
ROWS = 256  # rows per block where a whole-grid temporary would cost a vector of N² (b, the division, the checks)


def parse(argv):
    ap = Parser(prog="python -m bench.dst_poisson", description=__doc__,
                formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=positive(int), default=512, help="interior points per dimension (default 512)")
    ap.add_argument("--fft", choices=["scipy", "fftw"], default="scipy", help="the DST-I (default scipy)")
    ap.add_argument("--threads", type=positive(int), default=os.cpu_count(), help="threads (default: all)")
    record.add_options(ap)
    return ap.parse_args(argv)


def make_b(n):
    """b = h² f in row blocks (row j = y_j, column i = x_i, as bin/poisson --solution), and sin² of the grid."""
    import numpy as np
    h = 1.0 / (n + 1)
    c = np.arange(1, n + 1) * h
    s2, c2 = np.sin(np.pi * c) ** 2, np.cos(2 * np.pi * c)
    b = np.empty((n, n))
    scale = -2 * np.pi ** 2 * h * h
    for j0 in range(0, n, ROWS):
        j1 = min(n, j0 + ROWS)
        np.multiply.outer(s2[j0:j1], c2, out=b[j0:j1])
        b[j0:j1] += np.multiply.outer(c2[j0:j1], s2)
        b[j0:j1] *= scale
    return b, s2


def divide(v, n):
    """v /= λ_i + λ_j in row blocks, with the scale of the inverse transform."""
    import numpy as np
    lam = 2 - 2 * np.cos(np.pi * np.arange(1, n + 1) / (n + 1))
    for j0 in range(0, n, ROWS):
        j1 = min(n, j0 + ROWS)
        v[j0:j1] /= lam[j0:j1, None] + lam[None, :]


class Fftw:
    """A 2-D RODFT00 plan on one array, in place, through ctypes."""

    def __init__(self, v, threads):
        name = ctypes.util.find_library("fftw3") or "libfftw3.so.3"
        try:
            self.lib = ctypes.CDLL(name, mode=ctypes.RTLD_GLOBAL)
            thr = ctypes.CDLL(ctypes.util.find_library("fftw3_threads") or "libfftw3_threads.so.3")
        except OSError as e:
            raise UsageError(f"FFTW 3 is not installed ({e}); apt-get install libfftw3-double3") from None
        thr.fftw_init_threads()
        thr.fftw_plan_with_nthreads(ctypes.c_int(threads))
        self.lib.fftw_plan_r2r_2d.restype = ctypes.c_void_p
        self.lib.fftw_plan_r2r_2d.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p,
                                             ctypes.c_int, ctypes.c_int, ctypes.c_uint]
        self.lib.fftw_execute.argtypes = [ctypes.c_void_p]
        self.lib.fftw_destroy_plan.argtypes = [ctypes.c_void_p]
        ptr = v.ctypes.data
        n0, n1 = v.shape
        self.plan = self.lib.fftw_plan_r2r_2d(n0, n1, ptr, ptr, FFTW_RODFT00, FFTW_RODFT00, FFTW_ESTIMATE)
        if not self.plan:
            raise UsageError(f"FFTW made no RODFT00 plan for {n0} x {n1}")
        # fftw_version is a char array (not a pointer): its address is the string
        self.version = ctypes.string_at(ctypes.addressof(ctypes.c_char.in_dll(self.lib, "fftw_version"))).decode()

    def run(self):
        self.lib.fftw_execute(self.plan)


def checks(u, b, s2):
    """‖b − A u‖² / ‖b‖² and max |u − u_exact|, in row blocks (A: the h²-scaled 5-point matrix, zero outside)."""
    import numpy as np
    n = u.shape[0]
    rr = bb = err = 0.0
    for j0 in range(0, n, ROWS):
        j1 = min(n, j0 + ROWS)
        au = 4 * u[j0:j1]
        au[:, 1:] -= u[j0:j1, :-1]
        au[:, :-1] -= u[j0:j1, 1:]
        if j0 > 0:  # the row above (none above row 0)
            au -= u[j0 - 1:j1 - 1]
        else:
            au[1:] -= u[:j1 - 1]
        if j1 < n:  # the row below (none below row n - 1)
            au -= u[j0 + 1:j1 + 1]
        else:
            au[:-1] -= u[j0 + 1:j1]
        rr += float(np.sum((b[j0:j1] - au) ** 2))
        bb += float(np.sum(b[j0:j1] ** 2))
        err = max(err, float(np.max(np.abs(u[j0:j1] - np.multiply.outer(s2[j0:j1], s2)))))
    return (rr / bb) ** 0.5 if bb > 0 else 0.0, err


def solve(a):
    import numpy as np
    import scipy
    import scipy.fft as sf
    n = a.n
    t = time.perf_counter()
    b, s2 = make_b(n)
    libs = {"numpy": np.__version__, "scipy": scipy.__version__}
    if a.fft == "fftw":
        v = np.empty_like(b)
        plan = Fftw(v, a.threads)  # FFTW_ESTIMATE does not touch v
        libs["fftw"] = plan.version
    setup_s = time.perf_counter() - t
    t = time.perf_counter()
    if a.fft == "fftw":
        np.copyto(v, b)
        plan.run()
        divide(v, n)
        v *= 1.0 / (2.0 * (n + 1)) ** 2
        plan.run()
        u = v
    else:
        u = sf.dstn(b, type=1, workers=a.threads)
        divide(u, n)
        u = sf.idstn(u, type=1, workers=a.threads, overwrite_x=True)
    solve_s = time.perf_counter() - t
    t = time.perf_counter()
    true_rel, err = checks(u, b, s2)
    check_s = time.perf_counter() - t
    return u, libs, {"setup": setup_s, "solve": solve_s, "per_iteration": solve_s, "check": check_s}, true_rel, err


def main(argv=None):
    try:
        a = parse(sys.argv[1:] if argv is None else argv)
        u, libs, times, true_rel, err = solve(a)
    except UsageError as e:
        print(f"dst_poisson: {e}", file=sys.stderr)
        return 2
    n = a.n
    rec = record.make("peer", libs)
    rec["params"] = {"peer": f"dst-{a.fft}", "n": n, "backend": "fftw" if a.fft == "fftw" else "scipy.fft",
                     "precond": "dst", "method": "dst", "precision": "double", "threads": a.threads,
                     "matrix": "5-point, h²-scaled, diagonalised by DST-I in x and y"}
    rec["result"] = {"status": "converged", "converged": True, "iterations": 0, "true_rel_residual": true_rel,
                     "error_inf": err, "h": 1.0 / (n + 1)}
    rec["times_s"] = times
    rec["perf"] = {"timer": "host wall clock (time.perf_counter)", "dof_per_s": n * n / times["solve"]}
    rec["backend_info"] = {"threads": str(a.threads), "transform": "RODFT00 (FFTW_ESTIMATE)" if a.fft == "fftw"
                           else "scipy.fft.dstn type 1"}
    record.set_outcome(rec, record.EXIT_OK, "")
    if not a.quiet:
        print(f"dst_poisson: N={n} fft={a.fft} threads={a.threads}\n  direct: true relative residual {true_rel:.3e}, "
              f"||u - u_h||_inf = {err:.4e}\n  time: setup {times['setup']:.4f} s, solve {times['solve']:.4f} s "
              f"({rec['perf']['dof_per_s']:.4g} DOF/s), check {times['check']:.4f} s")
    record.emit(rec, a)
    return 0


if __name__ == "__main__":
    sys.exit(main())
