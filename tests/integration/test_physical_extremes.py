"""Answers that are physical at the extremes (issue 54). With emission and reflectivity non-negative, B = E + ρF E +
(ρF)² E + ... >= E wherever an answer exists; where ρF has spectral radius 1 or more (a closed lossless box, a box of
reflectivity 1.2) there is none, and every method in both precisions must end with no answer (exit 3, or 4 at
--max-iter), never 0, its record saying why (BiCG-STAB's algebraic solution, negative, is refused as unphysical by
the one check of radiosity/solve/physical.hpp). The same boxes at rho = 0.99 keep their answer, within 0.2% of the
exact answer of the stored F, E / (1 - rho s) with s its rows' sum. The --tol advice names a value that is accepted."""
import json
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import ROOT, run
from conftest import MPI_ENV
from mpi_files import mpi_built

sys.path.insert(0, str(ROOT / "bench"))
import ff_file  # noqa: E402

BIN = ROOT / "bin" / "radiosity"
BOXES = ROOT / "radiosity" / "scenes" / "extremes"
METHODS = (["--method", "jacobi"], ["--method", "gauss-seidel"], ["--method", "sor", "--omega", "1.2"],
           ["--method", "bicgstab"])
GE1 = ["--allow-reflectivity-ge-1"]


@pytest.fixture(scope="module")
def boxes(tmp_path_factory):
    """{rho: (scene, its form factors)} of the closed boxes, 192 patches, hemicube R = 64 (exact weights)."""
    tmp = tmp_path_factory.mktemp("boxes")
    out = {}
    for rho in ("1", "1.2", "0.99"):
        scene, ff = BOXES / f"box_rho{rho}.xml", tmp / f"rho{rho}.ff"
        p = run([BIN, "formfactors", scene, *GE1, "--divide", "0.1", "-o", ff, "--hemicube", "64", "--weights", "exact",
                 "--quiet"])
        assert p.returncode == 0, p.stderr
        out[rho] = (scene, ff)
    return out


def solve(scene, ff, *args, rec=None, mpi=None):
    cmd = [BIN, "solve", scene, *GE1, "--divide", "0.1", "--ff", ff, "--tol", "1e-6", "--max-iter", "20000",
           "--quiet", *args]
    if rec is not None:
        cmd += ["--record", rec]
    if mpi:
        return run(["mpirun", "-np", str(mpi), *cmd, "--backend", "mpi"], env=MPI_ENV, timeout=600)
    return run(cmd, timeout=600)


@pytest.mark.parametrize("rho", ["1", "1.2"])
def test_where_the_light_is_amplified_no_method_in_either_precision_gives_an_answer(boxes, rho, tmp_path):
    scene, ff = boxes[rho]
    rec = tmp_path / "rec.jsonl"
    for method in METHODS:
        for prec in ("float", "double"):
            p = solve(scene, ff, *method, "--precision", prec, "--threads", "2", rec=rec)
            assert p.returncode in (3, 4), (rho, method, prec, p.returncode, p.stderr)
            assert len(p.stderr.strip().splitlines()) == 1, p.stderr
            r = json.loads(rec.read_text().splitlines()[-1])["result"]
            assert r["exit_status"] == p.returncode and r["exit_reason"], r
            assert r["status"] in ("stagnant", "divergent", "breakdown", "nonfinite", "unphysical", "max_iter"), r
            assert "radiosity_min" not in r or p.returncode != 0
    # BiCG-STAB in double finds the algebraic solution, negative: refused as unphysical, with the patch, the channel
    # and the smallest B - E named, and why
    last = [json.loads(l)["result"] for l in rec.read_text().splitlines()][-1]
    assert last["status"] == "unphysical", last
    assert "the light is amplified, not absorbed (the spectral radius of rho F is 1 or more)" in last["exit_reason"]
    assert last["exit_reason"].startswith("unphysical: B - E = -") and " at patch " in last["exit_reason"]


def test_below_one_the_answer_stands_within_0_2_percent_of_the_stored_fs_exact_answer(boxes, tmp_path):
    scene, ff = boxes["0.99"]
    header, values = ff_file.read(ff)
    n = header["n"]
    s = np.asarray(values, dtype=np.float64).reshape(n, n).sum(axis=1)
    exact = 1 / (1 - 0.99 * s)  # E = 1 on every patch; B of the box is uniform up to the rows' sums
    answered = 0
    for method in METHODS:
        for prec in ("float", "double"):
            p = solve(scene, ff, *method, "--precision", prec, "--threads", "2", "--json")
            assert p.returncode in (0, 4), (method, prec, p.stderr)  # float Gauss-Seidel may stop short of 1e-6
            if p.returncode:
                continue
            r = json.loads(p.stdout.splitlines()[-1])["result"]
            b = np.asarray(r["radiosity_min"] + r["radiosity_max"])
            assert np.all(np.abs(b / exact.mean() - 1) < 2e-3), (method, prec, b, exact.min(), exact.max())
            answered += 1
    assert answered >= 6  # Jacobi and BiCG-STAB in both precisions at least


def test_mpi_and_the_relight_basis_refuse_the_amplifying_box_too(boxes, tmp_path):
    scene, ff = boxes["1.2"]
    if mpi_built():
        p = solve(scene, ff, "--method", "bicgstab", "--precision", "double", "--json", mpi=2)
        assert p.returncode == 3, p.stderr
        assert "unphysical: B - E = " in p.stderr and "amplified, not absorbed" in p.stderr, p.stderr
    p = run([BIN, "relight", scene, *GE1, "--divide", "0.1", "--ff", ff, "--random-frames", "2", "--quiet"])
    assert p.returncode == 3 and "light basis" in p.stderr, (p.returncode, p.stderr)


@pytest.mark.parametrize("prec", ["float", "double"])
def test_the_tol_advice_is_a_value_that_is_accepted(boxes, prec):
    scene, ff = boxes["0.99"]
    low = {"float": "1e-9", "double": "1e-18"}[prec]
    p = run([BIN, "solve", scene, *GE1, "--divide", "0.1", "--ff", ff, "--precision", prec, "--tol", low])
    assert p.returncode == 2 and "use --tol " in p.stderr, p.stderr
    advised = p.stderr.split("use --tol ")[1].split()[0]
    assert float(advised) > float(low), p.stderr
    q = run([BIN, "solve", scene, *GE1, "--divide", "0.1", "--ff", ff, "--precision", prec, "--tol", advised,
             "--max-iter", "1", "--quiet"])
    assert q.returncode == 4, q.stderr  # accepted: it runs, and stops at --max-iter 1
