#!/usr/bin/python3
"""bench/petsc_poisson.py: PETSc's CG on bin/poisson's problem, the peer of `make bench` for --precond mg.

    mpirun -np P /usr/bin/python3 bench/petsc_poisson.py --n N --pc none|hypre|gamg|mg [--tol T] [--max-iter K]
                                                        [--record FILE] [--json] [--quiet]

The same problem, right-hand side, start, tolerance and norm as bin/poisson: -Δu = f on the unit square, N × N
interior points, h = 1/(N+1), u = sin²(πx) sin²(πy), the h²-scaled 5-point matrix (4 on the diagonal, -1 per
neighbour) assembled as AIJ in the row layout of a 2-D DMDA on 1 × P processes (so PETSc's ordering is the natural
one, index j·N + i), b = h² f, x₀ = 0, KSPCG with the UNPRECONDITIONED norm, rtol = T, atol = 0. Preconditioners:
none (plain CG, whose iterations must equal ours), hypre (BoomerAMG with PETSc's defaults), gamg (PETSc's
algebraic multigrid with its defaults), mg (PETSc's geometric multigrid, PCMG on the DMDA's own hierarchy: the
DMDA coarsened by 2 per level down to 5 × 5, its interpolation, Galerkin coarse operators, one Richardson sweep of
symmetric SOR before and after, so that the V-cycle is symmetric as CG needs; N must be 2^k + 1, k >= 3, the sizes
a DMDA halves to the end). Times: setup (assembly), pc_setup (ksp.setUp: the multigrid hierarchy), solve
(ksp.solve only); error ‖u − u_h‖∞ against the exact solution, true residual ‖b − Ax‖/‖b‖ recomputed.

Debian's petsc4py (python3-petsc4py, `make deps`) runs only under /usr/bin/python3 and needs
PETSC_DIR=/usr/lib/petscdir/petsc3.18/x86_64-linux-gnu-real when Python starts (it restarts itself with it). Bad arguments: exit 2 with
one line on stderr; stopped by --max-iter: exit 4, broken down: exit 3, each with its record (common/errors.hpp). The record (rank 0 only) follows common/record.py's schema, app "peer"."""
import argparse
import os
import sys
import time
from pathlib import Path

# Debian's petsc4py is found through PETSC_DIR when Python starts (a .pth file reads it), so without it this
# script starts itself again with it set (before MPI starts, so under mpirun too).
if "PETSC_DIR" not in os.environ:
    os.environ["PETSC_DIR"] = "/usr/lib/petscdir/petsc3.18/x86_64-linux-gnu-real"
    os.execv(sys.executable, [sys.executable, *sys.argv])
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from common import record  # noqa: E402  (standard library only, so /usr/bin/python3 can import it)
from bench.peers import positive  # noqa: E402  (NumPy is imported inside its functions only)

PCS = {"none": "none", "hypre": "hypre", "gamg": "gamg", "mg": "mg"}
NAMES = {"none": "PETSc CG", "hypre": "PETSc CG + hypre BoomerAMG", "gamg": "PETSc CG + GAMG",
         "mg": "PETSc CG + geometric MG (DMDA)"}


def mg_levels(n):
    """PCMG's levels for N = 2^k + 1 (the DMDA halves N - 1 each level, down to 5 points); None for another N."""
    k = (n - 1).bit_length() - 1
    return k - 1 if n >= 9 and n - 1 == 1 << k else None


class Parser(argparse.ArgumentParser):
    def error(self, message):
        print(f"petsc_poisson: {message} (see --help)", file=sys.stderr)
        sys.exit(2)


def parse(argv):
    ap = Parser(prog="bench/petsc_poisson.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=positive(int), default=512, help="interior points per dimension (default 512)")
    ap.add_argument("--pc", choices=sorted(PCS), default="none", help="preconditioner (default none)")
    ap.add_argument("--tol", type=positive(float), default=1e-6, help="relative residual tolerance (default 1e-6)")
    ap.add_argument("--max-iter", type=positive(int), help="iteration limit (default max(1000, 4N), as bin/poisson)")
    record.add_options(ap)
    return ap.parse_args(argv)


def assemble(np, PETSc, comm, n):
    """The h²-scaled 5-point matrix A on a 2-D DMDA of 1 x P processes, b = h² f, the exact solution u and the DMDA."""
    h = 1.0 / (n + 1)
    da = PETSc.DMDA().create(dim=2, sizes=(n, n), proc_sizes=(1, comm.getSize()), stencil_width=1,
                             stencil_type=PETSc.DMDA.StencilType.STAR, comm=comm)
    da.setUp()
    (xs, xe), (ys, ye) = da.getRanges()
    assert (xs, xe) == (0, n)
    # Local rows j in [ys, ye), all i: global index j*n + i (natural = PETSc ordering on 1 x P processes).
    jj, ii = np.meshgrid(np.arange(ys, ye), np.arange(n), indexing="ij")
    jj, ii = jj.ravel(), ii.ravel()
    row = jj * n + ii
    cols, vals = [row], [np.full(row.size, 4.0)]
    for di, dj in ((-1, 0), (1, 0), (0, -1), (0, 1)):
        ok = (ii + di >= 0) & (ii + di < n) & (jj + dj >= 0) & (jj + dj < n)
        cols.append(np.where(ok, row + di + dj * n, -1))
        vals.append(np.where(ok, -1.0, 0.0))
    C, V = np.stack(cols, 1), np.stack(vals, 1)
    keep = C >= 0
    counts = keep.sum(1)
    indptr = np.concatenate([[0], np.cumsum(counts)]).astype(PETSc.IntType)
    order = np.argsort(np.where(keep, C, np.iinfo(np.int64).max), axis=1, kind="stable")
    C, V = np.take_along_axis(C, order, 1), np.take_along_axis(V, order, 1)
    keep = np.take_along_axis(keep, order, 1)
    local = row.size
    A = PETSc.Mat().createAIJ(size=((local, n * n), (local, n * n)),
                              csr=(indptr, C[keep].astype(PETSc.IntType), V[keep]), comm=comm)
    A.assemble()
    x_c, y_c = (ii + 1) * h, (jj + 1) * h
    sx, sy = np.sin(np.pi * x_c), np.sin(np.pi * y_c)
    f = -2 * np.pi ** 2 * (np.cos(2 * np.pi * x_c) * sy ** 2 + sx ** 2 * np.cos(2 * np.pi * y_c))
    b = da.createGlobalVec()
    b.setArray(h * h * f)
    u = b.duplicate()
    u.setArray((sx * sy) ** 2)
    return A, b, u, da


def make_ksp(PETSc, comm, A, da, a, max_iter):
    """KSPCG on A with the unpreconditioned norm, rtol = --tol, atol = 0, x₀ = 0 and the preconditioner --pc."""
    ksp = PETSc.KSP().create(comm=comm)
    ksp.setOperators(A)
    ksp.setType(PETSc.KSP.Type.CG)
    ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
    ksp.setTolerances(rtol=a.tol, atol=0.0, max_it=max_iter)
    ksp.setInitialGuessNonzero(False)
    pc = ksp.getPC()
    pc.setType(PCS[a.pc])
    if a.pc == "mg":
        ksp.setDM(da)
        ksp.setDMActive(False)  # the operator is A, assembled above; the DMDA gives only the grid hierarchy
        opts = PETSc.Options()
        for key, value in (("pc_mg_levels", mg_levels(a.n)), ("pc_mg_galerkin", "both"),
                           ("mg_levels_ksp_type", "richardson"), ("mg_levels_ksp_max_it", 1),
                           ("mg_levels_pc_type", "sor")):
            opts[key] = value
        pc.setFromOptions()
    return ksp


def check(PETSc, A, b, u, x):
    """The true relative residual ‖b − Ax‖/‖b‖, recomputed, and the error ‖u − x‖∞ (x is overwritten)."""
    r = b.duplicate()
    A.mult(x, r)
    r.aypx(-1.0, b)
    bn = b.norm()
    true_rel = r.norm() / bn if bn > 0 else 0.0
    x.axpy(-1.0, u)
    return true_rel, x.norm(PETSc.NormType.INFINITY)


def solve(np, PETSc, comm, a, n, max_iter):
    """Assembles, sets up and solves; returns the result's fields and the times (setup, pc_setup, solve)."""
    t = time.perf_counter()
    A, b, u, da = assemble(np, PETSc, comm, n)
    x = b.duplicate()
    x.set(0.0)
    ksp = make_ksp(PETSc, comm, A, da, a, max_iter)
    setup_s = time.perf_counter() - t
    t = time.perf_counter()
    ksp.setUp()
    pc_setup_s = time.perf_counter() - t
    comm.barrier()
    t = time.perf_counter()
    ksp.solve(b, x)
    comm.barrier()
    solve_s = time.perf_counter() - t
    true_rel, err = check(PETSc, A, b, u, x)
    return ksp.getIterationNumber(), ksp.getConvergedReason(), true_rel, err, (setup_s, pc_setup_s, solve_s)


def report(a, rec, exit_status, why):
    """Prints the summary (unless --quiet), writes the record, and names a run that is no answer on stderr."""
    p, r, ts = rec["params"], rec["result"], rec["times_s"]
    if not a.quiet:
        print(f"petsc_poisson: N={p['n']} {NAMES[a.pc]} ranks={p['ranks']}\n  status {r['status']} after "
              f"{r['iterations']} iterations: true relative residual {r['true_rel_residual']:.3e}, ||u - u_h||_inf = "
              f"{r['error_inf']:.4e}\n  time: setup {ts['setup']:.3f} s, pc setup {ts['pc_setup']:.3f} s, solve "
              f"{ts['solve']:.3f} s ({1e3 * ts['per_iteration']:.4g} ms/iteration)")
    record.set_outcome(rec, exit_status, why)
    record.emit(rec, a)
    if exit_status != record.EXIT_OK:
        print(f"petsc_poisson: {why}", file=sys.stderr)


def main(argv):
    a = parse(argv)
    if a.pc == "mg" and mg_levels(a.n) is None:
        print(f"petsc_poisson: --pc mg needs N = 2^k + 1 (9, 17, ..., 4097: the sizes a DMDA halves down to 5 "
              f"points), not {a.n}", file=sys.stderr)
        return 2
    try:
        import numpy as np
        from petsc4py import PETSc
    except ImportError as e:
        print(f"petsc_poisson: petsc4py is not installed ({e}); make deps installs python3-petsc4py", file=sys.stderr)
        return 2
    comm = PETSc.COMM_WORLD
    rank, size = comm.getRank(), comm.getSize()
    if a.pc == "hypre" and not PETSc.Sys.hasExternalPackage("hypre"):
        if rank == 0:
            print("petsc_poisson: this PETSc was built without hypre", file=sys.stderr)
        return 2
    n = a.n
    max_iter = a.max_iter or max(1000, 4 * n)
    h = 1.0 / (n + 1)
    its, reason, true_rel, err, (setup_s, pc_setup_s, solve_s) = solve(np, PETSc, comm, a, n, max_iter)
    status = "converged" if reason > 0 else "max_iter" if reason == -3 else "breakdown"
    # every rank ends with the run's exit status (common/errors.hpp); rank 0 alone writes the record
    exit_status = record.EXIT_OK if reason > 0 else record.EXIT_NOT_CONVERGED if reason == -3 else \
        record.EXIT_NUMERICAL
    why = (f"true relative residual {true_rel:.3e} after {its} iterations (--max-iter {max_iter}), above --tol "
           f"{a.tol:.1e}") if reason == -3 else f"KSPCG did not converge (KSPConvergedReason {int(reason)})"
    if rank != 0:
        return exit_status
    libs = {"petsc": ".".join(map(str, PETSc.Sys.getVersion())), "numpy": np.__version__}
    rec = record.make("peer", libs)
    rec["params"] = {"peer": f"petsc-cg-{a.pc}", "n": n, "backend": "petsc", "precond": a.pc, "precision": "double",
                     "tol": a.tol, "max_iter": max_iter, "ranks": size, "threads": 1,
                     "matrix": "AIJ 5-point, h²-scaled, DMDA layout 1 x P"}
    rec["result"] = {"status": status, "converged": reason > 0, "converged_reason": int(reason), "iterations": its,
                     "true_rel_residual": float(true_rel), "error_inf": float(err), "h": h}
    rec["times_s"] = {"setup": setup_s, "pc_setup": pc_setup_s, "solve": solve_s,
                      "per_iteration": solve_s / its if its else 0.0}
    rec["perf"] = {"timer": "host wall clock (time.perf_counter) around ksp.solve, barriers before and after"}
    rec["backend_info"] = {"ranks": str(size), "threads": "1", "solver": NAMES[a.pc]}
    report(a, rec, exit_status, why)
    return exit_status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
