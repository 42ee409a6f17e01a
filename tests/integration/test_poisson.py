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
