"""bin/poisson --method fmg (issue 37): full multigrid, then V-cycles, to the same ||r||/||r0|| <= tol. Its
iterations do not grow with N, its error is the exact discrete solution's (bench/dst_poisson.py's DST solve), and
every backend agrees with serial."""
import argparse
import json

import numpy as np
import pytest

from bench import dst_poisson
from conftest import BIN, have_mpi, poisson, run
from test_poisson import assert_matches, solve

requires_mpi = pytest.mark.skipif(not have_mpi(), reason="bin/poisson built without MPI or no mpirun")


def test_iterations_are_flat_in_n():
    its = {}
    for n in (63, 127, 255, 256, 511, 1000, 1023, 2047):
        p, rec = poisson("--n", n, "--backend", "openmp", "--threads", 2, "--method", "fmg")
        assert p.returncode == 0, p.stderr
        assert rec["result"]["status"] == "converged" and rec["result"]["true_rel_residual"] <= 1e-6
        its[n] = rec["result"]["iterations"]
    # 5 on this problem for every N (N = 63 .. 2047, odd and even): the F-cycle, then four V-cycles of ~0.075 each
    assert max(its.values()) - min(its.values()) <= 1 and max(its.values()) <= 6, its


def dst(n, fft):
    return dst_poisson.solve(argparse.Namespace(n=n, fft=fft, threads=1))


@pytest.mark.parametrize("fft", ["scipy", "fftw"])
def test_dst_is_the_exact_discrete_solution(fft):
    u, _, _, true_rel, err = dst(63, fft)
    assert true_rel <= 1e-12
    h = 1 / 64
    c = np.arange(1, 64) * h
    assert abs(err - np.max(np.abs(u - np.multiply.outer(np.sin(np.pi * c) ** 2, np.sin(np.pi * c) ** 2)))) == 0


# ||u - u_h||_inf of FMG to 1e-6 equals that of the exact discrete solution to 3 digits, and u_h is within 1% of
# that error of it everywhere (the algebraic error is far below the discretisation error).
@pytest.mark.parametrize("backend", ["serial", "openmp"])
def test_error_equals_the_exact_discrete_solutions(tmp_path, backend):
    rec, x = solve(tmp_path, "fmg", "--n", 255, "--backend", backend, "--method", "fmg")
    u, _, _, _, err = dst(255, "scipy")
    assert f"{rec['result']['error_inf']:.2e}" == f"{err:.2e}", (rec["result"]["error_inf"], err)
    assert abs(rec["result"]["error_inf"] - err) <= 1e-3 * err
    assert np.max(np.abs(x - u)) <= 1e-2 * err


@pytest.fixture(scope="module")
def serial_fmg(tmp_path_factory):
    d = tmp_path_factory.mktemp("serial_fmg")
    return {n: solve(d, f"ser{n}", "--n", n, "--backend", "serial", "--method", "fmg") for n in (5, 100, 257)}


@pytest.mark.parametrize("threads", [1, 3])
def test_openmp_fmg_matches_serial(tmp_path, serial_fmg, threads):
    for n in (5, 100, 257):
        rec, x = solve(tmp_path, "omp", "--n", n, "--backend", "openmp", "--threads", threads, "--method", "fmg")
        assert rec["result"]["iterations"] == serial_fmg[n][0]["result"]["iterations"]
        assert_matches(rec, x, serial_fmg[n])


# Levels split across ranks (N = 257 on 2 ranks) and gathered at once (N = 100 on 7), P > N (N = 5 on 7).
@requires_mpi
@pytest.mark.parametrize("n,ranks", [(5, 7), (100, 3), (100, 7), (257, 2), (257, 4)])
def test_mpi_fmg_matches_serial(tmp_path, serial_fmg, n, ranks):
    rec, x = solve(tmp_path, "mpi", "--n", n, "--backend", "mpi", "--method", "fmg", np_=ranks)
    assert rec["params"]["method"] == "fmg" and rec["params"]["ranks"] == ranks
    assert rec["result"]["iterations"] == serial_fmg[n][0]["result"]["iterations"]
    assert_matches(rec, x, serial_fmg[n])


def test_record_says_method_and_dof_per_s():
    p, rec = poisson("--n", 64, "--backend", "openmp", "--method", "fmg")
    assert p.returncode == 0, p.stderr
    assert rec["params"]["method"] == "fmg" and rec["params"]["precond"] == "none"
    assert rec["result"]["mg_levels"] == [64, 32, 16, 8, 4, 2, 1]
    per_level = rec["perf"]["fmg_vectors_per_level"]
    assert len(per_level) == 7 and per_level[0] == 9.0 and all(v > 0 for v in per_level[:-1])
    assert rec["perf"]["dof_per_s"] == pytest.approx(64 * 64 / rec["times_s"]["solve"])
    p, rec = poisson("--n", 64, "--backend", "openmp")
    assert rec["params"]["method"] == "cg" and rec["perf"]["dof_per_s"] > 0


# Each backend's F-cycle by its own kernels (poisson/methods/mg.hpp): openmp's fused level kernels cycle on x (the finest
# level's transfers 2.5 and cycle from x 6.5, nothing after); serial's separate kernels cycle on the correction z
# (transfers 5.25 + 3.25, cycle from x 14.5, then x += z and r = b - A x: 6). The record's bytes and bandwidth
# follow that model: the F-cycle as the first iteration, vectors_per_iteration for each one after it.
@pytest.mark.parametrize("backend,finest,correction", [("openmp", 2.5 + 6.5, 0), ("serial", 5.25 + 3.25 + 14.5, 6)])
def test_bandwidth_follows_the_backends_own_fmg_model(backend, finest, correction):
    p, rec = poisson("--n", 64, "--backend", backend, "--threads", 1, "--method", "fmg")
    assert p.returncode == 0, p.stderr
    perf, its = rec["perf"], rec["result"]["iterations"]
    assert perf["fmg_vectors_per_level"][0] == finest and perf["fmg_correction_vectors"] == correction
    vector = perf["bytes_per_iteration"] / perf["vectors_per_iteration"]
    assert vector == 8 * 64 * 64  # float64
    first = sum(perf["fmg_vectors_per_level"]) + correction
    assert perf["solve_bytes"] == pytest.approx((first + (its - 1) * perf["vectors_per_iteration"]) * vector)
    assert perf["bandwidth_GBps"] == pytest.approx(perf["solve_bytes"] / rec["times_s"]["solve"] / 1e9)


@pytest.mark.parametrize("fft", ["scipy", "fftw"])
def test_records_carry_the_whole_process(fft):
    """times_s.process: the process's life up to its record, start-up included, so never less than the phases it
    timed itself (bin/poisson's total; the DST solver's setup, solve and check, after the interpreter's start)."""
    import json
    import sys
    from conftest import ROOT
    p, rec = poisson("--n", 64, "--backend", "openmp", "--method", "fmg")
    assert p.returncode == 0, p.stderr
    t = rec["times_s"]
    assert t["total"] <= t["process"] < t["total"] + 60, t
    p = run([sys.executable, "-m", "bench.dst_poisson", "--n", "64", "--fft", fft, "--threads", "1", "--json",
             "--quiet"], cwd=ROOT)
    assert p.returncode == 0, p.stderr
    t = json.loads(p.stdout)["times_s"]
    assert t["setup"] + t["solve"] + t["check"] < t["process"] < 60, t


def test_fmg_targets_judge_solve_process_and_setup(monkeypatch):
    """Issue 37's lines at N = 8192, decided by the claims' one rule (issue 49) on intervals: solve and whole process
    each against the target, and against the fastest DST solver's paired per round (a row without a process time is
    left out of that comparison); the setup against 0.35 s or 1.2x the time of writing 3 vectors of N² at the triad
    next to it."""
    import pandas as pd
    from analysis import bench
    monkeypatch.setattr(bench, "target", lambda *a, **k: __import__("analysis.bench_records", fromlist=["target"])
                        .target(*a, **{**k, "margin": 0.05}))

    def recs(solve, process):
        return pd.DataFrame({"times_s.solve": [solve * (1 + 0.01 * k) for k in range(6)],
                             "times_s.process": [None if process is None else process * (1 + 0.01 * k)
                                                 for k in range(6)],
                             "provenance.env.HPCGI_REPEAT": [str(k) for k in range(6)],
                             "protocol.block": ["bench-mg"] * 6})

    def row(solver, solve, process):
        return {"solver": solver, "time to solution (s)": solve, "process (s)": process,
                "_recs": recs(solve, process)}
    rows = [row("ours: openmp FMG", 0.4, 0.9), row("DST-I (scipy.fft)", 0.6, 1.5), row("DST-I (FFTW)", 0.5, None)]
    setup = pd.Series([0.3] * 6)
    lines = bench._fmg_targets(8192, rows, setup, 25.0)
    assert any(l.startswith("FMG N=8192: solve: 0.41") and l.endswith(": confirmed") for l in lines), lines
    assert any(l.startswith("FMG N=8192: whole process: 0.92") and l.endswith(": confirmed") for l in lines), lines
    assert any("solve over that of the fastest DST solver's, DST-I (FFTW): 0.8x" in l and
               "6 pairs, interleaved" in l and l.endswith(": confirmed") for l in lines), lines
    assert any("whole process over that of the fastest DST solver's, DST-I (scipy.fft)" in l for l in lines), lines
    assert any(l.startswith("FMG N=8192: setup") and l.endswith(": confirmed") for l in lines), lines
    # 3 vectors of N² are 1.61 GB: 0.0644 s at 25 GB/s, 0.537 s at 3 GB/s (a setup of 0.5 s within 1.2x of that)
    assert any(l.startswith("FMG N=8192: setup") and "0.537 s" in l and l.endswith(": confirmed")
               for l in bench._fmg_targets(8192, rows, pd.Series([0.5] * 6), 3.0))
    lines = bench._fmg_targets(8192, [row("ours: openmp FMG", 0.7, 1.6)] + rows[1:], pd.Series([0.5] * 6), 25.0)
    assert [l.rsplit(": ", 1)[1] for l in lines] == ["refuted"] * 5, lines
    assert bench._fmg_targets(4096, rows, setup, 25.0) == []


BAD = [["--method", "multigrid"], ["--method", "fmg", "--precond", "mg"], ["--method", "fmg", "--variant", "onesweep"],
       ["--method", "fmg", "--backend", "cublas1"]]


@pytest.mark.parametrize("args", BAD, ids=[" ".join(a) for a in BAD])
def test_bad_method_exits_2_with_one_line(args):
    p = run([BIN / "poisson", *args], timeout=30)
    assert p.returncode == 2, (p.returncode, p.stderr)
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("poisson"), p.stderr


def test_gpu_fmg_matches_serial(tmp_path, requires_gpu, serial_fmg):
    for n in (5, 100, 257):
        rec, x = solve(tmp_path, "cuda", "--n", n, "--backend", "cuda", "--method", "fmg")
        assert rec["result"]["iterations"] == serial_fmg[n][0]["result"]["iterations"]
        assert_matches(rec, x, serial_fmg[n])


def test_bench_table_sets_fmg_beside_mg_pcg_and_the_dst_solver(tmp_path):
    """analysis.bench on bench-mg records at N = 64: rows for MG-PCG, FMG and both DST solvers, DOF/s on each."""
    import os
    import subprocess
    import sys
    from conftest import ROOT
    env = dict(os.environ, RESULTS=str(tmp_path / "results"), MACHINE="bench-test",
               ANALYSIS_ALL_RECORDS="1")  # records of this tree, clean or not
    res = tmp_path / "results" / "bench-test"
    p = run([BIN / "stream", "--size", 1 << 16, "--trials", 2, "--record", res / "bench-stream/quick.jsonl"])
    assert p.returncode == 0, p.stderr
    for args in (["--precond", "mg"], ["--method", "fmg"]):
        p = run([BIN / "poisson", "--backend", "openmp", "--n", "64", "--quiet", "--record",
                 res / "bench-mg/quick.jsonl", *args])
        assert p.returncode == 0, p.stderr
    for fft in ("scipy", "fftw"):
        p = run([sys.executable, "-m", "bench.dst_poisson", "--n", "64", "--fft", fft, "--threads", "1", "--quiet",
                 "--record", res / "bench-mg/quick.jsonl"], cwd=ROOT)
        assert p.returncode == 0, p.stderr
    p = subprocess.run([sys.executable, "-m", "analysis.bench", "quick"], cwd=ROOT, env=env, capture_output=True,
                       text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    table = (res / "tables" / "bench_quick.md").read_text()
    rows = [l for l in table.splitlines() if l.startswith("|") and ("MG-PCG" in l or "FMG" in l or "DST-I" in l)]
    assert len(rows) == 4, table
    header = next(l for l in table.splitlines() if l.startswith("|") and "DOF/s" in l)
    col = [c.strip() for c in header.split("|")].index("DOF/s")
    assert all(float([c.strip() for c in r.split("|")][col]) > 0 for r in rows), rows


def test_every_backend_stops_on_the_residual_of_its_new_x_in_float_too():
    """serial cycles on the correction z, then x += z and r = b - A x recomputed. With the recursive r -= A z it
    used to stop in float at 5 iterations on a residual 70x below the true one (exit 0, true ‖r‖/‖r0‖ 2.9e-5 at
    N = 65), where openmp, stopping on b - A x, never reached 1e-6: the same method, opposite verdicts."""
    got = {}
    for backend in ("serial", "openmp"):
        p = run([BIN / "poisson", "--n", 65, "--backend", backend, "--threads", 1, "--precision", "float", "--method",
                 "fmg", "--max-iter", 20, "--json", "--quiet"])
        got[backend] = (p.returncode, json.loads(p.stdout)["result"])  # the record is written either way
    rc, r = got["serial"]
    assert r["rel_residual"] == pytest.approx(r["true_rel_residual"], rel=1e-6), r
    assert rc == got["openmp"][0] == 4 and not r["converged"], got  # float's floor is above 1e-6 here
    assert r["true_rel_residual"] == pytest.approx(got["openmp"][1]["true_rel_residual"], rel=0.5), got
