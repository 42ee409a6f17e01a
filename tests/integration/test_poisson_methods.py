"""Issue 37, item 4: the report's Poisson section ends with the time to solution per method (CG, MG-PCG, FMG, DST) at
every N, each our fastest configuration with its interval and n, beside the report's p = 1, p = 16 and K20 columns.
Built here from a small fixture of records (table41 and bench-mg frames as analysis.records.load returns them)."""
import re
import sys

import numpy as np
import pandas as pd

from conftest import ROOT

sys.path.insert(0, str(ROOT))
from analysis import poisson_methods  # noqa: E402


def recs(n, times, **params):
    """One record per time, setup 10% of it, as load() flattens them."""
    app = params.pop("app", "poisson")
    status = params.pop("exit_status", 0)
    return [{"app": app, "exit_status": status, "result.status": "converged" if status == 0 else "max_iter",
             "params.n": n, "params.tol": 1e-6, "params.precision": "double", "provenance.cpus_online": 2,
             "provenance.host": "fixture", "times_s.setup": 0.1 * t, "times_s.solve": 0.9 * t,
             **{f"params.{k}": v for k, v in params.items()}} for t in times]


def fixture():
    t41 = pd.DataFrame(
        recs(1024, [3.4, 3.5, 3.3, 3.6, 3.45], backend="mpi", ranks=1, threads=1, precond="none")
        + recs(1024, [1.8, 1.9, 1.85, 1.75, 1.82], backend="mpi", ranks=2, threads=1, precond="none")
        + recs(1024, [0.05, 0.052, 0.049, 0.051, 0.05], backend="openmp", threads=2, precond="mg")
        + recs(1024, [0.001], backend="openmp", threads=2, precond="mg", exit_status=4))  # no answer: left out
    bench = pd.DataFrame(
        recs(1024, [0.04, 0.041, 0.039], backend="openmp", threads=2, precond="mg", method="cg")
        + recs(1024, [0.03, 0.031, 0.029, 0.03], backend="openmp", threads=2, method="fmg", precond="mg")
        + recs(1024, [0.02, 0.021, 0.022], app="peer", peer="dst-scipy", method="dst", precond="dst", threads=2,
               backend="scipy.fft")
        + recs(1024, [0.001, 0.001, 0.001], app="peer", peer="petsc", precond="hypre", ranks=2, backend="petsc"))
    return {"table41": t41, "bench-mg": bench}


def cells(table, n):
    row = table[table["N"] == n].iloc[0]
    return {c: row[c] for c in table.columns}


def parse(c):
    m = re.match(r"([\d.e-]+) \[([\d.e-]+), ([\d.e-]+)\] \d+% n=(\d+)", c)  # median [interval] its level n=runs
    assert m, c
    return float(m[1]), float(m[2]), float(m[3]), int(m[4])


def test_every_method_has_its_fastest_run_with_interval_and_n(monkeypatch):
    frames = fixture()
    monkeypatch.setattr(poisson_methods, "load", lambda exp, preset: frames.get(exp, pd.DataFrame()).copy())
    title, table, notes, detail = poisson_methods.build("quick")
    assert "Time to solution per method" in title
    row = cells(table, 1024)
    med, lo, hi, n = parse(row["ours CG"])
    assert n == 5 and abs(med - 1.82) < 1e-9 and lo <= med <= hi and "p2" in row["ours CG"]
    # MG-PCG: the bench's openmp runs (median 0.04) beat table41's (0.05); the no-answer run (0.001) is left out
    med, lo, hi, n = parse(row["ours MG-PCG"])
    assert n == 3 and abs(med - 0.04) < 1e-9 and "make bench" in row["ours MG-PCG"]
    med, _, _, n = parse(row["ours FMG"])
    assert n == 4 and abs(med - 0.03) < 1e-9
    med, _, _, n = parse(row["ours DST"])
    assert n == 3 and abs(med - 0.021) < 1e-9 and "dst-scipy" in row["ours DST"]
    # PETSc's peers are the bench table's, never a method of this one
    assert not (detail["median"] < 0.002).any()
    # the report's columns at every N it has, ours "—" where we did not run
    assert (row["report CG p1 (1 rank)"], row["report CG p16 (16 ranks)"], row["report CG K20 (cuBLAS 1)"]) == \
        (12.54, 0.62, 1.836455)
    assert cells(table, 8192)["ours CG"] == "—" and np.isfinite(cells(table, 8192)["report CG p16 (16 ranks)"])
    assert any("exit status 4" in n for n in notes) and any(n.startswith("Settings:") for n in notes)
    assert not any("No records of" in n for n in notes)


def test_a_method_without_records_is_named_with_where_it_runs(monkeypatch):
    frames = fixture()
    frames["bench-mg"] = frames["bench-mg"][frames["bench-mg"]["params.method"] != "fmg"]
    monkeypatch.setattr(poisson_methods, "load", lambda exp, preset: frames.get(exp, pd.DataFrame()).copy())
    _, table, notes, _ = poisson_methods.build("quick")
    assert cells(table, 1024)["ours FMG"] == "—"
    assert any("No records of FMG" in n and "--method fmg" in n for n in notes)
    monkeypatch.setattr(poisson_methods, "load", lambda exp, preset: pd.DataFrame())
    assert poisson_methods.build("quick") is None
