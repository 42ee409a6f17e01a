"""python -m bench.peers scipy-cg|numpy-jacobi ...: what a user would reach for instead of our solvers, on the
same problems, timed and recorded like them (schema hpcgi-record/1, --record/--json/--quiet as bin/*), for
`make bench`.

  scipy-cg      scipy.sparse.linalg.cg on the 5-point Laplacian of bin/poisson (CSR, the same h²-scaled system,
                right-hand side, zero start and stopping test ||r|| <= tol ||b||), --max-iter as bin/poisson's
  numpy-jacobi  Jacobi steps B <- E + rho * (F @ B) with NumPy's BLAS on the float32 form factors of a file from
                `bin/radiosity formfactors`; --way gemm: F @ B for the three channels at once (one sgemm with 3
                columns), --way gemv: three F @ b (three sgemv, three passes over F)

Threads: --threads sets OPENBLAS_NUM_THREADS and OMP_NUM_THREADS before NumPy loads. SciPy's sparse product is
single-threaded whatever they say; that is what a user gets.

Exit status as bin/poisson's and bin/radiosity's (common/errors.hpp), the record written for 3, 4 and 5: 0 an
answer, 2 bad arguments or input, 3 scipy-cg broke down, 4 scipy-cg stopped by --max-iter, 5 numpy-jacobi
disagreed with our B."""
import argparse
import os
import sys
import time
import xml.etree.ElementTree as ET

from common import record
from bench import ff_file


class UsageError(Exception):
    """Bad arguments or input: one line on stderr, exit status 2 (as hpcgi::UsageError)."""


class Parser(argparse.ArgumentParser):
    def error(self, message):
        raise UsageError(f"{message} (see --help)")


def positive(kind):
    def check(text):
        try:
            v = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
        if not v > 0 or v != v or v == float("inf"):
            raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
        return v
    return check


def parse(argv):
    ap = Parser(prog="python -m bench.peers", description=__doc__,
                formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="peer", required=True, parser_class=Parser)
    cg = sub.add_parser("scipy-cg", help="scipy.sparse.linalg.cg on bin/poisson's problem")
    cg.add_argument("--n", type=positive(int), default=512, help="interior points per dimension (default 512)")
    cg.add_argument("--tol", type=positive(float), default=1e-6, help="relative residual tolerance (default 1e-6)")
    cg.add_argument("--max-iter", type=positive(int), help="iteration limit (default max(1000, 4N), as bin/poisson)")
    jac = sub.add_parser("numpy-jacobi", help="Jacobi steps with NumPy's BLAS on a form-factor file")
    jac.add_argument("scene", help="the scene (RRV XML), as bin/radiosity solve takes it: named in the record")
    jac.add_argument("--ff", required=True, help="form-factor file of the scene (bin/radiosity formfactors)")
    jac.add_argument("--solved", required=True,
                     help="the same scene solved by `bin/radiosity solve --steps K --output FILE` with K = --steps: "
                          "E and rho per patch, and our B_K to check against")
    jac.add_argument("--steps", type=positive(int), default=32, help="Jacobi steps (default 32)")
    jac.add_argument("--way", choices=["gemm", "gemv"], default="gemm", help="F @ B (3 columns) or three F @ b")
    for p in (cg, jac):
        p.add_argument("--threads", type=positive(int), default=os.cpu_count(), help="BLAS threads (default: all)")
        record.add_options(p)
    return ap.parse_args(argv)


def libraries():
    import numpy as np
    libs = {"numpy": np.__version__}
    cfg = np.show_config(mode="dicts").get("Build Dependencies", {}).get("blas", {})
    libs["numpy_blas"] = f"{cfg.get('name', '?')} {cfg.get('version', '?')}"
    try:
        import scipy
        libs["scipy"] = scipy.__version__
    except ImportError:
        pass
    return libs


def scipy_cg(a):
    import numpy as np
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    n = a.n
    max_iter = a.max_iter or max(1000, 4 * n)
    t = time.perf_counter()
    h = 1.0 / (n + 1)
    c = np.arange(1, n + 1) * h  # x_i = (i + 1) h, the same in y (poisson/config/problem.hpp)
    X, Y = np.meshgrid(c, c)     # row j = y_j, column i = x_i: index j * n + i as bin/poisson --solution
    sx, sy = np.sin(np.pi * X), np.sin(np.pi * Y)
    f = -2 * np.pi ** 2 * (np.cos(2 * np.pi * X) * sy ** 2 + sx ** 2 * np.cos(2 * np.pi * Y))
    b = (h * h * f).ravel()
    T = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(n, n))
    A = (sp.kron(sp.identity(n), T) + sp.kron(T, sp.identity(n))).tocsr()
    setup_s = time.perf_counter() - t

    count = [0]
    def step(_):
        count[0] += 1
    t = time.perf_counter()
    x, info = spla.cg(A, b, rtol=a.tol, atol=0.0, maxiter=max_iter, callback=step)
    solve_s = time.perf_counter() - t
    t = time.perf_counter()
    bn = np.linalg.norm(b)
    true_rel = float(np.linalg.norm(b - A @ x) / bn) if bn > 0 else 0.0
    err = float(np.max(np.abs(x - (sx * sy).ravel() ** 2)))
    check_s = time.perf_counter() - t
    it = count[0]
    status = "converged" if info == 0 else "max_iter" if info > 0 else "breakdown"
    rec = record.make("peer", libraries())
    rec["params"] = {"peer": "scipy-cg", "n": n, "backend": "scipy", "precision": "double", "tol": a.tol,
                     "max_iter": max_iter, "threads": a.threads, "matrix": "CSR 5-point, h²-scaled"}
    rec["result"] = {"status": status, "converged": info == 0, "iterations": it,
                     "true_rel_residual": true_rel, "error_inf": err, "h": h}
    rec["times_s"] = {"setup": setup_s, "solve": solve_s, "per_iteration": solve_s / it if it else 0.0,
                      "check": check_s}
    rec["perf"] = {"timer": "host wall clock (time.perf_counter)"}
    rec["backend_info"] = {"threads": str(a.threads), "note": "CSR product single-threaded; dots and axpys by NumPy"}
    if info > 0:
        record.set_outcome(rec, record.EXIT_NOT_CONVERGED, f"true relative residual {true_rel:.3e} after {it} "
                           f"iterations (--max-iter {max_iter}), above --tol {a.tol:.1e}")
    else:
        record.set_outcome(rec, record.EXIT_OK if info == 0 else record.EXIT_NUMERICAL,
                           f"scipy.sparse.linalg.cg broke down (info {info})")
    if not a.quiet:
        print(f"scipy-cg: N={n} threads={a.threads}\n  status {status} after {it} iterations: true relative "
              f"residual {true_rel:.3e}, ||u - u_h||_inf = {err:.4e}\n  time: setup {setup_s:.3f} s, solve "
              f"{solve_s:.3f} s ({1e3 * rec['times_s']['per_iteration']:.4g} ms/iteration)")
    return rec


def read_solved(path):
    """E, rho, B (n × 3) and the triangles (three vertices each) of the patches of an RRV file written by
    bin/radiosity solve --output: one triangle per patch in patch order (grouped by entity, which keep their patches
    in order)."""
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as e:
        raise UsageError(f"{path}: cannot read the solved scene ({e})") from None
    E, rho, B, triangles = [], [], [], []
    colour = lambda t, k: [float(v) for v in t.get(k, "0,0,0").split(",")]
    for t in root.iter("triangle"):
        E.append(colour(t, "emission"))
        rho.append(colour(t, "reflectivity"))
        B.append(colour(t, "radiosity"))
        triangles.append([(float(v.get("x")), float(v.get("y")), float(v.get("z"))) for v in t.iter("vertex")])
    if not E or any(len(t) != 3 for t in triangles):
        raise UsageError(f"{path}: not a scene written by bin/radiosity solve --output (one triangle per patch)")
    return E, rho, B, triangles


def numpy_jacobi(a):
    import numpy as np

    t = time.perf_counter()
    E, rho, B_ours, triangles = read_solved(a.solved)
    n = len(E)
    try:
        F = ff_file.read_dense(a.ff, n, ff_file.mesh_hash(triangles))
    except ff_file.FileError as e:
        raise UsageError(str(e)) from None
    load_s = time.perf_counter() - t
    E = np.asarray(E, dtype=np.float32)
    rho = np.asarray(rho, dtype=np.float32)
    B_ours = np.asarray(B_ours)
    # B0 = E: RRV's start max(radiosity attribute, E), for scenes without radiosity attributes (room3.xml has none;
    # a scene with them shows up below as a disagreement with our B_K).
    if a.way == "gemm":
        B = E.copy()
        t = time.perf_counter()
        for _ in range(a.steps):
            B = E + rho * (F @ B)          # one sgemm, n × n times n × 3
        solve_s = time.perf_counter() - t
    else:
        Et, rt, Bt = E.T.copy(), rho.T.copy(), E.T.copy()
        t = time.perf_counter()
        for _ in range(a.steps):
            Bt = np.stack([Et[c] + rt[c] * (F @ Bt[c]) for c in range(3)])  # three sgemv
        solve_s = time.perf_counter() - t
        B = Bt.T
    diff = float(np.max(np.abs(B - B_ours)) / max(np.max(np.abs(B_ours)), 1e-300))
    per_step = solve_s / a.steps
    passes = 1 if a.way == "gemm" else 3
    matrix_bytes = 4.0 * n * n
    rec = record.make("peer", libraries())
    rec["params"] = {"peer": "numpy-jacobi", "command": "solve", "scene": a.scene, "method": "jacobi", "way": a.way,
                     "backend": f"numpy-{a.way}", "layout": "aos" if a.way == "gemm" else "soa",
                     "precision": "float", "patches": n, "steps": a.steps, "threads": a.threads, "ff_file": a.ff,
                     "solved": a.solved}
    rec["result"] = {"status": "steps_done", "iterations": a.steps}
    rec["verify"] = {"reference": "B after the same steps from bin/radiosity solve (float, openmp)",
                     "max_rel_diff": diff, "bound": 1e-4, "agreed": diff <= 1e-4}
    rec["times_s"] = {"ff_load": load_s, "solve": solve_s, "per_iteration": per_step}
    rec["perf"] = {"matrix_bytes": matrix_bytes, "matrix_passes": passes * a.steps,
                   "bandwidth_GBps": passes * matrix_bytes / per_step / 1e9, "timer": "host wall clock"}
    rec["backend_info"] = {"threads": str(a.threads)}
    agreed = rec["verify"]["agreed"]
    record.set_outcome(rec, record.EXIT_OK if agreed else record.EXIT_DISAGREED,
                       f"disagreed with its float64 check: the result differs from ours by {diff:.2e} (bound 1e-4)")
    if not a.quiet:
        print(f"numpy-jacobi ({a.way}): {n} patches, {a.steps} steps, {a.threads} threads\n  agrees with our B to "
              f"{diff:.2e} (bound 1e-4)\n  time: load {load_s:.3f} s, solve {solve_s:.4f} s "
              f"({1e3 * per_step:.4g} ms/step, {rec['perf']['bandwidth_GBps']:.2f} GB/s)")
    return rec


def main(argv=None):
    try:
        a = parse(sys.argv[1:] if argv is None else argv)
        os.environ["OPENBLAS_NUM_THREADS"] = os.environ["OMP_NUM_THREADS"] = str(a.threads)
        rec = scipy_cg(a) if a.peer == "scipy-cg" else numpy_jacobi(a)
    except UsageError as e:
        print(f"peers: {e}", file=sys.stderr)
        return 2
    record.emit(rec, a)
    status = rec["result"]["exit_status"]  # 4 not converged, 5 disagreed: no answer, recorded (common/errors.hpp)
    if status != record.EXIT_OK:
        print(f"peers: {rec['result']['exit_reason']}", file=sys.stderr)
    return status


if __name__ == "__main__":
    sys.exit(main())
