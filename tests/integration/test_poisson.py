"""bin/poisson end to end: convergence order, every backend against serial, MPI layouts, float, bad arguments,
records and solutions, GPU backends where a GPU exists."""
import json

import numpy as np
import pytest

from conftest import BIN, MPI_ENV, have_mpi, poisson, run

requires_mpi = pytest.mark.skipif(not have_mpi(), reason="bin/poisson built without MPI or no mpirun")


def solve(tmp_path, name, *args, np_=None):
    sol = tmp_path / f"{name}.bin"
    p, rec = poisson(*args, "--solution", sol, np=np_)
    assert p.returncode == 0, p.stderr
    n = rec["params"]["n"]
    return rec, np.fromfile(sol, dtype="<f8").reshape(n, n)


def test_discretisation_error_is_second_order():
    errors = []
    for n in (31, 63, 127, 255):
        p, rec = poisson("--n", n, "--backend", "openmp", "--tol", "1e-10")
        assert p.returncode == 0, p.stderr
        assert rec["result"]["status"] == "converged"
        errors.append(rec["result"]["error_inf"])
    ratios = [a / b for a, b in zip(errors, errors[1:])]
    assert all(abs(r - 4) <= 0.3 for r in ratios), ratios


@pytest.fixture(scope="module")
def serial100(tmp_path_factory):
    return solve(tmp_path_factory.mktemp("serial"), "serial", "--n", 100, "--backend", "serial")


def assert_matches(rec, x, ref):
    ref_rec, ref_x = ref
    assert rec["result"]["status"] == "converged"
    assert abs(rec["result"]["iterations"] - ref_rec["result"]["iterations"]) <= 1
    rel = np.max(np.abs(x - ref_x)) / np.max(np.abs(ref_x))
    assert rel <= 1e-10, rel


@pytest.mark.parametrize("variant", ["classic", "onesweep"])
@pytest.mark.parametrize("threads", [1, 2, 3])
def test_openmp_matches_serial(tmp_path, serial100, threads, variant):
    rec, x = solve(tmp_path, "omp", "--n", 100, "--backend", "openmp", "--threads", threads, "--variant", variant)
    assert rec["params"]["threads"] == threads and rec["params"]["variant"] == variant
    assert_matches(rec, x, serial100)


@pytest.mark.parametrize("backend,precision,variant,vectors", [
    ("openmp", "double", "onesweep", 6), ("openmp", "float", "classic", 11), ("serial", "double", "classic", 13)])
def test_default_variant_is_recorded(backend, precision, variant, vectors):
    p, rec = poisson("--n", 32, "--backend", backend, "--precision", precision)
    assert p.returncode == 0, p.stderr
    assert rec["params"]["variant"] == variant
    assert rec["perf"]["vectors_per_iteration"] == vectors


# N = 5 on 3, 4 and 7 ranks leaves ranks with one row or none: onesweep's two halo rows then come from two ranks
# away (passed on in a second round); on 2 ranks they go in one message.
@requires_mpi
@pytest.mark.parametrize("variant", ["classic", "onesweep"])
@pytest.mark.parametrize("n", [5, 100])
@pytest.mark.parametrize("ranks", [1, 2, 3, 4, 7])
@pytest.mark.parametrize("halo", ["nonblocking", "blocking"])
def test_mpi_matches_serial(tmp_path, n, ranks, halo, variant):
    ref = solve(tmp_path, "ser", "--n", n, "--backend", "serial")
    rec, x = solve(tmp_path, "mpi", "--n", n, "--backend", "mpi", "--halo", halo, "--variant", variant, np_=ranks)
    assert rec["params"]["ranks"] == ranks and rec["params"]["halo"] == halo
    assert rec["params"]["variant"] == variant
    assert_matches(rec, x, ref)


@requires_mpi
def test_mpi_with_openmp_threads_matches_serial(tmp_path, serial100):
    rec, x = solve(tmp_path, "hyb", "--n", 100, "--backend", "mpi", "--threads", 2, np_=2)
    assert rec["params"]["threads"] == 2 and rec["params"]["ranks"] == 2
    assert_matches(rec, x, serial100)


def test_float_reports_its_true_residual(tmp_path):
    p, rec = poisson("--n", 512, "--backend", "openmp", "--precision", "float")
    assert p.returncode == 0, p.stderr
    r = rec["result"]
    assert rec["params"]["precision"] == "float"
    assert r["rel_residual"] <= 1e-6
    # float cannot hold x accurately enough for the true residual of this system to reach 1e-6: it must say so
    assert r["true_rel_residual"] > 1e-6 and r["true_residual_meets_tol"] is False
    text = run([BIN / "poisson", "--n", 512, "--backend", "openmp", "--precision", "float"]).stdout
    assert "true residual" in text and "above tol" in text


def test_record_is_appended_with_provenance(tmp_path):
    path = tmp_path / "deep" / "poisson.jsonl"
    for _ in range(2):
        p, _ = poisson("--n", 64, "--backend", "openmp", "--record", path)
        assert p.returncode == 0, p.stderr
    recs = [json.loads(l) for l in path.read_text().splitlines()]
    assert len(recs) == 2
    r = recs[0]
    assert r["schema"] == "hpcgi-record/1" and r["app"] == "poisson"
    assert r["perf"]["bytes_per_iteration"] == r["perf"]["vectors_per_iteration"] * 8 * 64 * 64
    assert r["perf"]["bandwidth_GBps"] > 0 and r["times_s"]["solve"] > 0
    for k in ("git_commit", "compiler", "cpu_model", "host", "utc"):
        assert r["provenance"][k]


def test_max_iter_reached_exits_4_and_writes_its_record_only(tmp_path):
    """A run stopped by --max-iter is no answer: exit 4, one line, the record (status max_iter, exit_status 4), no
    solution file; --steps K runs exactly K iterations (the benchmarks' time per iteration) and exits 0."""
    rec, sol = tmp_path / "r.jsonl", tmp_path / "u.bin"
    p = run([BIN / "poisson", "--n", "512", "--max-iter", "10", "--record", rec, "--solution", sol])
    assert p.returncode == 4, (p.returncode, p.stderr)
    assert p.stderr.startswith("poisson: not converged: relative residual") and len(p.stderr.splitlines()) == 1
    assert "status max_iter after 10 iterations" in p.stdout and not sol.exists()
    r = json.loads(rec.read_text())
    assert r["result"]["status"] == "max_iter" and r["result"]["exit_status"] == 4
    assert r["result"]["exit_reason"] in p.stderr
    p, r = poisson("--n", 512, "--steps", 10, "--backend", "openmp")
    assert p.returncode == 0, p.stderr
    assert r["result"]["status"] == "steps_done" and r["result"]["iterations"] == 10
    assert r["params"]["steps"] == 10 and r["params"]["tol"] is None and r["result"]["exit_status"] == 0


@requires_mpi
def test_max_iter_under_mpi_exits_4_on_every_rank(tmp_path):
    rec = tmp_path / "r.jsonl"
    p = run(["mpirun", "-np", "2", BIN / "poisson", "--backend", "mpi", "--n", "64", "--max-iter", "3", "--quiet",
             "--record", rec], env=MPI_ENV)
    assert p.returncode == 4, (p.returncode, p.stderr)
    assert p.stderr.count("poisson: not converged") == 1, p.stderr
    assert len(rec.read_text().splitlines()) == 1


BAD = [
    ["--n", "0"],
    ["--n", "-5"],
    ["--n", "ten"],
    ["--tol", "0"],
    ["--tol", "-1e-6"],
    ["--tol", "nan"],
    ["--tol", "abc"],
    ["--max-iter", "0"],
    ["--backend", "fortran"],
    ["--precision", "half"],
    ["--halo", "sometimes"],
    ["--variant", "pipelined"],
    ["--backend", "serial", "--variant", "onesweep"],
    ["--threads", "0"],
    ["--no-such-flag"],
    ["--precond", "ilu"],
    ["--precond", "mg", "--variant", "onesweep"],
    ["--precond", "mg", "--backend", "cublas1"],
    ["--precond", "mg", "--backend", "cublas2"],
    ["--check-symmetry"],
    ["--steps", "0"],
    ["--steps", "5", "--tol", "1e-3"],
    ["--steps", "5", "--max-iter", "10"],
]


@pytest.mark.parametrize("args", BAD, ids=[" ".join(a) for a in BAD])
def test_bad_arguments_exit_2_with_one_line(args):
    p = run([BIN / "poisson", *args], timeout=30)
    assert p.returncode == 2, (p.returncode, p.stderr)
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("poisson"), p.stderr
    assert p.stdout == ""


@pytest.mark.parametrize("backend", ["cublas1", "cublas2", "cuda"])
def test_cuda_backend_without_gpu_exits_2(backend):
    from conftest import gpu_absent_reason
    if gpu_absent_reason() is None:
        pytest.skip("a GPU is present: this test checks the refusal on machines without one")
    p = run([BIN / "poisson", "--backend", backend, "--n", "8"], timeout=60)
    assert p.returncode == 2, p.stderr
    assert len(p.stderr.strip().splitlines()) == 1


@requires_mpi
def test_non_mpi_backend_under_mpirun_is_refused():
    p = run(["mpirun", "-np", "2", BIN / "poisson", "--backend", "serial", "--n", "8"], env=MPI_ENV, timeout=60)
    assert p.returncode != 0
    assert "use --backend mpi" in p.stderr


@pytest.mark.parametrize("backend,variant", [("cublas1", "classic"), ("cublas2", "classic"), ("cuda", "classic"),
                                             ("cuda", "onesweep")])
@pytest.mark.parametrize("precision", ["double", "float"])
def test_gpu_backend_matches_serial(tmp_path, requires_gpu, serial100, backend, variant, precision):
    rec, x = solve(tmp_path, backend, "--n", 100, "--backend", backend, "--precision", precision, "--variant", variant)
    assert rec["params"]["variant"] == variant
    assert rec["backend_info"]["gpu"]
    if precision == "double":
        assert_matches(rec, x, serial100)
    else:
        ref_rec, ref_x = serial100
        assert rec["result"]["status"] == "converged"
        assert np.max(np.abs(x - ref_x)) <= 1e-3 * np.max(np.abs(ref_x))


# N = 300 spans three tiles of the one-sweep kernel across and ten down: tile edges are where it could go wrong.
def test_cuda_onesweep_across_tiles_matches_serial(tmp_path, requires_gpu):
    ref = solve(tmp_path, "ser", "--n", 300, "--backend", "serial")
    rec, x = solve(tmp_path, "cuda", "--n", 300, "--backend", "cuda", "--variant", "onesweep")
    assert_matches(rec, x, ref)


def test_help_lists_backends_and_exits_0():
    p = run([BIN / "poisson", "--help"])
    assert p.returncode == 0
    for b in ("serial", "openmp", "mpi", "cublas1", "cublas2", "cuda"):
        assert b in p.stdout
    assert "Exit status: 0 an answer" in p.stdout and "4 not converged within --max-iter" in p.stdout


# --precond mg (poisson/methods/mg.hpp): CG preconditioned by one multigrid V-cycle, every backend against serial.
@pytest.fixture(scope="module")
def serial_mg(tmp_path_factory):
    d = tmp_path_factory.mktemp("serial_mg")
    return {n: solve(d, f"ser{n}", "--n", n, "--backend", "serial", "--precond", "mg") for n in (5, 100, 257)}


def test_precond_is_recorded_and_none_is_the_default():
    p, rec = poisson("--n", 32, "--backend", "openmp")
    assert p.returncode == 0 and rec["params"]["precond"] == "none" and "mg_levels" not in rec["result"]
    p, rec = poisson("--n", 32, "--backend", "openmp", "--precond", "mg")
    assert p.returncode == 0, p.stderr
    assert rec["params"]["precond"] == "mg" and rec["params"]["variant"] == "classic"
    assert rec["result"]["mg_levels"] == [32, 16, 8, 4, 2, 1]
    assert rec["result"]["iterations"] <= 12


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_openmp_mg_matches_serial(tmp_path, serial_mg, threads):
    for n in (5, 100, 257):
        rec, x = solve(tmp_path, "omp", "--n", n, "--backend", "openmp", "--threads", threads, "--precond", "mg")
        assert rec["result"]["iterations"] == serial_mg[n][0]["result"]["iterations"]
        assert_matches(rec, x, serial_mg[n])


# P not dividing N, P > N (N = 5 on 7 ranks), and levels split across ranks (N = 257 on 2 ranks: 128 rows, then
# 64, 32, 16, 8 per rank before the coarse levels are gathered) as well as gathered at once (N = 100 on 7).
@requires_mpi
@pytest.mark.parametrize("n", [5, 100, 257])
@pytest.mark.parametrize("ranks", [1, 2, 3, 4, 7])
def test_mpi_mg_matches_serial(tmp_path, serial_mg, n, ranks):
    rec, x = solve(tmp_path, "mpi", "--n", n, "--backend", "mpi", "--precond", "mg", np_=ranks)
    assert rec["params"]["ranks"] == ranks and rec["params"]["precond"] == "mg"
    assert rec["result"]["iterations"] == serial_mg[n][0]["result"]["iterations"]
    assert_matches(rec, x, serial_mg[n])


@requires_mpi
@pytest.mark.parametrize("halo", ["blocking", "nonblocking"])
def test_mpi_mg_with_threads_and_halo_matches_serial(tmp_path, serial_mg, halo):
    rec, x = solve(tmp_path, "mpi", "--n", 257, "--backend", "mpi", "--precond", "mg", "--threads", 2, "--halo", halo,
                   np_=2)
    assert rec["result"]["iterations"] == serial_mg[257][0]["result"]["iterations"]
    assert_matches(rec, x, serial_mg[257])


# The fused passes of mg_cpu.hpp split each threaded level's rows among the threads (levels of >= 2^16 points):
# at N = 513 on 2 ranks with 2 and 3 threads the two finest levels are split among ranks and threads (256 rows of
# 513 per rank), and openmp with 3 threads splits the whole levels down to N = 256.
@requires_mpi
@pytest.mark.parametrize("threads", [2, 3])
def test_mg_threaded_split_levels_match_serial(tmp_path, threads):
    ref = solve(tmp_path, "ser", "--n", 513, "--backend", "serial", "--precond", "mg")
    for backend, ranks in (("mpi", 2), ("openmp", None)):
        rec, x = solve(tmp_path, backend, "--n", 513, "--backend", backend, "--precond", "mg", "--threads", threads,
                       np_=ranks)
        assert rec["result"]["iterations"] == ref[0]["result"]["iterations"]
        assert_matches(rec, x, ref)


# (M⁻¹x)·y = x·(M⁻¹y) to 1e-12 relative on random x, y, on every CPU backend and rank count.
@pytest.mark.parametrize("backend,ranks", [("serial", None), ("openmp", None), *(("mpi", r) for r in (1, 2, 3, 4, 7))])
@pytest.mark.parametrize("n", [100, 257])
def test_mg_preconditioner_is_symmetric(backend, ranks, n):
    if backend == "mpi" and not have_mpi():
        pytest.skip("bin/poisson built without MPI or no mpirun")
    p, rec = poisson("--n", n, "--backend", backend, "--precond", "mg", "--check-symmetry", np=ranks)
    assert p.returncode == 0, p.stderr
    assert rec["result"]["mg_asymmetry"] <= 1e-12


@pytest.mark.parametrize("precision", ["double", "float"])
def test_gpu_mg_matches_serial(tmp_path, requires_gpu, serial_mg, precision):
    for n in (5, 100, 257):
        rec, x = solve(tmp_path, "cuda", "--n", n, "--backend", "cuda", "--precond", "mg", "--precision", precision)
        ref_rec, ref_x = serial_mg[n]
        if precision == "double":
            assert rec["result"]["iterations"] == ref_rec["result"]["iterations"]
            assert_matches(rec, x, serial_mg[n])
        else:
            assert rec["result"]["status"] == "converged"
            assert np.max(np.abs(x - ref_x)) <= 1e-3 * np.max(np.abs(ref_x))


def test_gpu_mg_preconditioner_is_symmetric(requires_gpu):
    p, rec = poisson("--n", 257, "--backend", "cuda", "--precond", "mg", "--check-symmetry")
    assert p.returncode == 0, p.stderr
    assert rec["result"]["mg_asymmetry"] <= 1e-12
