"""bench/petsc_poisson.py, the PETSc peer of `make bench` (bench-mg): the same problem in the same norm as
bin/poisson, so plain CG takes our iterations and every preconditioner reaches our error (the discretization's),
and PCMG on the DMDA (--pc mg) refuses the sizes a DMDA cannot halve to the end."""
import json
import subprocess

import pytest

from conftest import MPI_ENV, ROOT, have_mpi, poisson, run

PEER = ["/usr/bin/python3", str(ROOT / "bench" / "petsc_poisson.py")]


def petsc4py_missing():
    p = subprocess.run(["/usr/bin/python3", "-c", "import petsc4py"], capture_output=True,
                       env={"PETSC_DIR": "/usr/lib/petscdir/petsc3.18/x86_64-linux-gnu-real", "PATH": "/usr/bin:/bin"})
    return p.returncode != 0


pytestmark = pytest.mark.skipif(petsc4py_missing(), reason="petsc4py is not installed under /usr/bin/python3 "
                                                            "(make deps installs python3-petsc4py)")


def peer(*args, np=None):
    cmd = [*PEER, *map(str, args), "--json", "--quiet"]
    if np:
        cmd = ["mpirun", "-np", str(np), *cmd]
    p = run(cmd, env=MPI_ENV if np else None, cwd=ROOT, timeout=300)
    lines = [l for l in p.stdout.splitlines() if l.startswith("{")]
    return p, json.loads(lines[-1]) if lines else None


def test_plain_cg_takes_our_iterations():
    _, ours = poisson("--n", 65, "--backend", "serial")
    p, rec = peer("--n", 65, "--pc", "none")
    assert p.returncode == 0, p.stderr
    assert rec["result"]["iterations"] == ours["result"]["iterations"]
    assert rec["result"]["error_inf"] == pytest.approx(ours["result"]["error_inf"], rel=1e-6)


@pytest.mark.parametrize("np", [None, 2])
def test_geometric_mg_converges_in_a_few_iterations_to_our_error(np):
    if np and not have_mpi():
        pytest.skip("no mpirun")
    _, ours = poisson("--n", 129, "--backend", "serial", "--precond", "mg")
    p, rec = peer("--n", 129, "--pc", "mg", np=np)
    assert p.returncode == 0, p.stderr
    assert rec["params"]["precond"] == "mg" and rec["result"]["converged"]
    assert rec["result"]["iterations"] <= 8, rec["result"]  # plain CG takes about 200 here
    assert rec["result"]["true_rel_residual"] <= 1e-6
    assert rec["result"]["error_inf"] == pytest.approx(ours["result"]["error_inf"], rel=1e-3)


@pytest.mark.parametrize("n", [64, 4096, 5])
def test_geometric_mg_refuses_a_size_the_dmda_cannot_halve(n, tmp_path):
    out = tmp_path / "r.jsonl"
    p = run([*PEER, "--n", n, "--pc", "mg", "--record", out], cwd=ROOT, timeout=60)
    assert p.returncode == 2, (p.returncode, p.stderr)
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("petsc_poisson: --pc mg needs N = 2^k + 1"), p.stderr
    assert not out.exists()


def test_bench_table_sets_petsc_geometric_mg_beside_ours(tmp_path):
    """analysis.bench on bench-mg records at N = 65: PETSc's geometric MG in the rows of our MG-PCG."""
    import os
    import sys
    from conftest import BIN
    env = dict(os.environ, RESULTS=str(tmp_path / "results"), MACHINE="bench-test",
               ANALYSIS_ALL_RECORDS="1")  # records of this tree, clean or not
    res = tmp_path / "results" / "bench-test"
    assert run([BIN / "stream", "--size", 1 << 16, "--trials", 2, "--record", res / "bench-stream/quick.jsonl"]
               ).returncode == 0
    p = run([BIN / "poisson", "--backend", "openmp", "--n", "65", "--precond", "mg", "--quiet", "--record",
             res / "bench-mg/quick.jsonl"])
    assert p.returncode == 0, p.stderr
    p = run([*PEER, "--n", "65", "--pc", "mg", "--quiet", "--record", res / "bench-mg/quick.jsonl"], cwd=ROOT)
    assert p.returncode == 0, p.stderr
    p = subprocess.run([sys.executable, "-m", "analysis.bench", "quick"], cwd=ROOT, env=env, capture_output=True,
                       text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    table = (res / "tables" / "bench_quick.md").read_text()
    rows = [l for l in table.splitlines() if l.startswith("|") and ("MG-PCG" in l or "geometric MG" in l)]
    assert len(rows) == 2 and "PETSc CG + geometric MG (DMDA, Galerkin), 1 ranks" in rows[1], table
