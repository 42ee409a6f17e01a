"""bin/poisson's float64 check (poisson/verify.hpp): the record's verify section against a bound recomputed here
from its stated formula, a planted failure (HPCGI_TEST_POISSON_BOUND tightens the bound) that exits 5 with its
record, under one process and under MPI, and runs that are no answer left unchecked."""
import json
import math

import numpy as np
import pytest

from conftest import BIN, MPI_ENV, have_mpi, poisson, run

requires_mpi = pytest.mark.skipif(not have_mpi(), reason="bin/poisson built without MPI or no mpirun")
PLANT = {"HPCGI_TEST_POISSON_BOUND": "1e-3"}


def stated_bound(n, rho, eps):
    """pi^4 h^2/6 + rho ||b||_2 / (8 sin^2(pi h/2)) + eps, with ||b||_2 summed point by point (the program sums it
    through its separable form)."""
    h = 1.0 / (n + 1)
    x = np.arange(1, n + 1) * h
    X, Y = np.meshgrid(x, x, indexing="ij")
    sx, sy = np.sin(np.pi * X) ** 2, np.sin(np.pi * Y) ** 2
    b = h * h * -2 * np.pi ** 2 * (np.cos(2 * np.pi * X) * sy + sx * np.cos(2 * np.pi * Y))
    return np.pi ** 4 * h * h / 6 + rho * np.linalg.norm(b) / (8 * math.sin(np.pi * h / 2) ** 2) + eps


@pytest.mark.parametrize("args,rho,eps", [
    (["--n", "100", "--backend", "openmp"], 1e-6, np.finfo(np.float64).eps),
    (["--n", "63", "--backend", "serial", "--precision", "float", "--tol", "1e-5"], 1e-5, np.finfo(np.float32).eps),
    (["--n", "127", "--backend", "openmp", "--method", "fmg"], 1e-6, np.finfo(np.float64).eps),
])
def test_an_answer_agrees_within_the_stated_bound(args, rho, eps):
    p, r = poisson(*args)
    assert p.returncode == 0, p.stderr
    v, n = r["verify"], r["params"]["n"]
    assert v["agreed"] is True and v["error_inf"] == r["result"]["error_inf"] <= v["bound"]
    assert v["bound"] == pytest.approx(stated_bound(n, rho, eps), rel=1e-9)
    assert v["bound"] == pytest.approx(sum(v["bound_terms"].values()), rel=1e-12)
    assert "test_factor" not in v


def test_fixed_steps_are_checked_against_their_own_residual():
    p, r = poisson("--n", "64", "--backend", "openmp", "--steps", "5")
    assert p.returncode == 0, p.stderr
    rho = r["result"]["rel_residual"]
    assert r["verify"]["agreed"] is True
    assert r["verify"]["bound"] == pytest.approx(stated_bound(64, rho, np.finfo(np.float64).eps), rel=1e-9)


def test_a_planted_failure_exits_5_with_its_record_and_no_solution(tmp_path):
    rec, sol = tmp_path / "r.jsonl", tmp_path / "u.bin"
    p = run([BIN / "poisson", "--n", "64", "--backend", "openmp", "--record", rec, "--solution", sol], env=PLANT)
    assert p.returncode == 5, (p.returncode, p.stderr)
    assert p.stderr.startswith("poisson: disagreed with its float64 check: ||u - u_h||_inf = ")
    assert len(p.stderr.splitlines()) == 1 and not sol.exists()
    r = json.loads(rec.read_text())
    assert r["result"]["exit_status"] == 5 and r["result"]["exit_reason"] in p.stderr
    assert r["result"]["status"] == "converged"  # converged, and yet no answer: the check failed
    v = r["verify"]
    assert v["agreed"] is False and v["test_factor"] == 1e-3 and v["error_inf"] > v["bound"]
    assert v["bound"] == pytest.approx(1e-3 * stated_bound(64, 1e-6, np.finfo(np.float64).eps), rel=1e-9)


@requires_mpi
def test_a_planted_failure_under_mpi_exits_5_once(tmp_path):
    rec = tmp_path / "r.jsonl"
    p = run(["mpirun", "-np", "2", "-x", "HPCGI_TEST_POISSON_BOUND", BIN / "poisson", "--backend", "mpi", "--n", "64",
             "--quiet", "--record", rec], env={**MPI_ENV, **PLANT})
    assert p.returncode == 5, (p.returncode, p.stderr)
    assert p.stderr.count("poisson: disagreed with its float64 check") == 1, p.stderr
    (line,) = rec.read_text().splitlines()
    assert json.loads(line)["verify"]["agreed"] is False


def test_no_answer_is_not_checked_and_a_bad_hook_is_refused(tmp_path):
    rec = tmp_path / "r.jsonl"
    p = run([BIN / "poisson", "--n", "64", "--max-iter", "3", "--record", rec], env=PLANT)
    assert p.returncode == 4, p.stderr  # not converged comes first: nothing to check
    assert json.loads(rec.read_text())["verify"] == {"agreed": None}
    for bad in ("0", "2", "x", "nan"):
        p = run([BIN / "poisson", "--n", "8"], env={"HPCGI_TEST_POISSON_BOUND": bad})
        assert p.returncode == 2 and "HPCGI_TEST_POISSON_BOUND" in p.stderr, (bad, p.stderr)
