"""Radiosity across MPI ranks (issue 9), through the real program under mpirun: form factors written by P = 1..4
ranks are the serial program's bytes; --backend mpi on P = 1..4 ranks gives the single-process openmp answer within
1e-6 relative (Jacobi and BiCG-STAB, AOS and SOA, a grey scene on one channel), reading a file written by any number
of ranks; the records say what each rank held and moved; a scene one rank may not hold (--max-memory-per-rank) is
refused with exit status 2 and one line, nothing written, and computed and solved on 4 ranks."""
import sys

import numpy as np
import pandas as pd
import pytest

from conftest import ROOT, run
from mpi_files import (HEMICUBE, MPI_BUILT, SCENES, form_factor_files, messages, radiosities, radiosity, record,
                       rel_diff)

pytestmark = pytest.mark.skipif(not MPI_BUILT, reason="bin/radiosity built without MPI, or no mpirun")


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    return form_factor_files(tmp_path_factory)


@pytest.mark.parametrize("ranks", [1, 2, 3, 4])
def test_form_factor_files_of_any_ranks_are_the_serial_bytes(files, ranks):
    d, out = files
    f, rec = out[ranks]
    assert f.read_bytes() == out["serial"][0].read_bytes()
    assert not (d / f"P{ranks}.ff.tmp").exists()
    n = rec["params"]["patches"]
    mpi = rec["mpi"]
    assert rec["params"]["ranks"] == mpi["ranks"] == ranks and rec["provenance"]["mpi_ranks"] == ranks
    assert sum(mpi["rank_rows"]) == n and len(mpi["rank_hemicube_s"]) == ranks
    assert mpi["rank_ff_bytes"] == [4 * r * n for r in mpi["rank_rows"]]
    assert all(x > 0 for x in mpi["rank_peak_rss_bytes"])
    # the row sums are every rank's rows together, as the serial program finds them
    for k in ("min_row_sum", "max_row_sum"):
        assert rec["result"][k] == pytest.approx(out["serial"][1]["result"][k], rel=1e-12)


def test_rows_are_split_by_work_not_by_count(files):
    _, out = files
    mpi = out[4][1]["mpi"]
    est = mpi["rank_estimated_s"]
    assert max(est) <= 1.1 * min(est), est  # the estimate is balanced ...
    assert len(set(mpi["rank_rows"])) > 1, mpi["rank_rows"]  # ... by rows of unequal work


@pytest.fixture(scope="module")
def openmp_answers(files):
    d, out = files
    answers = {}
    for method in ("jacobi", "bicgstab"):
        for layout in ("aos", "soa"):
            o = d / f"omp-{method}-{layout}.xml"
            rec = record(radiosity("solve", out["scene"], "--ff", out["serial"][0], "--method", method,
                                   "--layout", layout, "--tol", "1e-6", "--backend", "openmp", "--storage", "dense", "--threads", "2",
                                   "--output", o, "--json", "--quiet"))
            answers[method, layout] = (rec, radiosities(o))
    return answers


@pytest.mark.parametrize("ranks", [1, 2, 3, 4])
@pytest.mark.parametrize("method", ["jacobi", "bicgstab"])
@pytest.mark.parametrize("layout", ["aos", "soa"])
def test_mpi_backend_equals_one_process(files, openmp_answers, ranks, method, layout, tmp_path):
    _, out = files
    writer = {1: 3, 2: 1, 3: 4, 4: 2}[ranks]  # read a file written by another number of ranks
    o = tmp_path / "mpi.xml"
    rec = record(radiosity("solve", out["scene"], "--ff", out[writer][0], "--method", method,
                           "--layout", layout, "--tol", "1e-6", "--backend", "mpi", "--storage", "dense", "--output", o,
                           "--json", "--quiet", np_=ranks))
    ref, b_ref = openmp_answers[method, layout]
    b = radiosities(o)
    assert rel_diff(b, b_ref) <= 1e-6
    assert rec["result"]["iterations"] == ref["result"]["iterations"]
    assert rec["result"]["status"] == "converged" and rec["verify"]["agreed"] is True
    assert rec["result"]["max_rel_residual"] == pytest.approx(ref["result"]["max_rel_residual"], rel=1e-3)
    mpi = rec["mpi"]
    n = rec["params"]["patches"]
    assert rec["params"]["ranks"] == mpi["ranks"] == ranks and sum(mpi["rank_rows"]) == n
    assert mpi["rank_ff_bytes"] == [4 * r * n for r in mpi["rank_rows"]]
    # moved per iteration: each rank receives the other ranks' rows of every gathered vector (4-byte floats)
    per_gather = [(n - r) * 3 * 4 for r in mpi["rank_rows"]]
    got = mpi["rank_received_bytes_per_iteration"]
    assert all(g == pytest.approx(mpi["allgatherv_per_iteration"] * p) for g, p in zip(got, per_gather))
    # Jacobi gathers the radiosity once a step, BiCG-STAB p and s (and x at a restart); one rank holds every row
    gathers = 0 if ranks == 1 else 1 if method == "jacobi" else 2
    assert mpi["allgatherv_per_iteration"] == pytest.approx(gathers, abs=0.35)
    assert mpi["allreduce_per_iteration"] >= 1
    assert len(mpi["rank_comm_s"]) == ranks


def test_jacobi_fixed_steps_give_the_same_bits_on_any_ranks(files, tmp_path):
    """A row's sums are the same code on any rank and thread: fixed Jacobi steps (no dot in the iterate) match
    backend openmp bit for bit, in double as in float."""
    _, out = files
    answers = []
    for ranks in (None, 3):
        o = tmp_path / f"{ranks}.xml"
        args = ["solve", out["scene"], "--ff", out["serial"][0], "--steps", "20", "--precision",
                "double", "--output", o, "--json", "--quiet", "--no-verify"]
        record(radiosity(*args, "--backend", "openmp", "--storage", "dense") if ranks is None else
               radiosity(*args, "--backend", "mpi", "--storage", "dense", np_=ranks))
        answers.append(radiosities(o))
    assert np.array_equal(answers[0], answers[1])


def test_grey_scene_is_solved_as_one_channel_across_ranks(tmp_path):
    ff = tmp_path / "box.ff"
    box = SCENES / "closed_box.xml"
    record(radiosity("formfactors", box, "--divide", "0.05", "-o", ff, *HEMICUBE, "--json", "--quiet", np_=2))
    outs = {}
    for ranks in (None, 3):
        o = tmp_path / f"{ranks}.xml"
        # in double: float's BiCG-STAB stops at --max-iter 1000 with the residual 1.1e-7 (no answer, exit 4)
        args = ["solve", box, "--divide", "0.05", "--ff", ff, "--method", "bicgstab", "--tol", "1e-8", "--precision",
                "double", "--output", o, "--json", "--quiet"]
        rec = record(radiosity(*args) if ranks is None else radiosity(*args, "--backend", "mpi", np_=ranks))
        assert rec["result"]["channels"] == 1
        outs[ranks] = radiosities(o)
    assert rel_diff(outs[3], outs[None]) <= 1e-6


def test_only_rank_0_writes(files, tmp_path):
    _, out = files
    o, png, rec_file = tmp_path / "o.xml", tmp_path / "o.png", tmp_path / "r.jsonl"
    p = radiosity("solve", out["scene"], "--ff", out[2][0], "--steps", "4", "--backend", "mpi",
                  "--output", o, "--png", png, "--size", "32x24", "--record", rec_file, np_=3)
    assert p.returncode == 0, p.stderr
    assert p.stdout.count("solve: ") == 1 and o.exists() and png.exists()
    assert len(rec_file.read_text().splitlines()) == 1


def test_corrupted_file_refused_by_every_rank_with_one_line(files, tmp_path):
    _, out = files
    bad = tmp_path / "bad.ff"
    data = bytearray(out["serial"][0].read_bytes())
    n = out["serial"][1]["params"]["patches"]
    data[72 + 4 * (n * n // 2 + 5)] ^= 0x40  # a value in the middle rank's rows
    bad.write_bytes(bytes(data))
    p = radiosity("solve", out["scene"], "--ff", bad, "--backend", "mpi", "--output", tmp_path / "o.xml",
                  np_=3)
    assert p.returncode == 2
    assert messages(p) == [f"radiosity: corrupted form-factor file '{bad}': checksum mismatch"], p.stderr
    assert not (tmp_path / "o.xml").exists()


def test_non_mpi_backend_under_mpirun_is_refused(files):
    _, out = files
    p = radiosity("solve", out["scene"], "--ff", out[1][0], "--backend", "openmp", np_=2)
    assert p.returncode == 2 and "use --backend mpi" in p.stderr


# scene2 (3360 patches): dense F is 43.1 MiB. At 16 MiB per rank, the form factors need 4 ranks by the work split
# (3 by equal counts, which the program then takes), a solve 4 ranks (3 would hold 14.4 MiB of F and 2 MiB of
# vectors each).
LIMIT = ["--max-memory-per-rank", "16M"]


@pytest.fixture(scope="module")
def large(tmp_path_factory):
    d = tmp_path_factory.mktemp("large")
    ff = d / "scene2.ff"
    p = radiosity("formfactors", SCENES / "scene2.xml", *HEMICUBE, "-o", ff, *LIMIT, "--json", "--quiet", np_=4)
    return d, ff, record(p)


def test_too_large_for_one_rank_is_refused_with_exit_2_and_nothing_written(large, tmp_path):
    _, ff, _ = large
    mine = tmp_path / "one.ff"
    for np_ in (None, 1, 2):
        p = radiosity("formfactors", SCENES / "scene2.xml", *HEMICUBE, "-o", mine, *LIMIT, np_=np_)
        assert p.returncode == 2, p.stderr
        lines = messages(p)
        assert len(lines) == 1 and "more than --max-memory-per-rank 16.0 MiB" in lines[0], p.stderr
        assert "on 3 ranks" in lines[0] and "mpirun -np 3" in lines[0], lines[0]
        assert not mine.exists() and not (tmp_path / "one.ff.tmp").exists()
    for np_, backend in ((None, "openmp"), (1, "mpi"), (3, "mpi")):
        o = tmp_path / "o.xml"
        p = radiosity("solve", SCENES / "scene2.xml", "--ff", ff, "--backend", backend, *LIMIT, "--output", o, np_=np_)
        assert p.returncode == 2 and not o.exists(), p.stderr
        lines = messages(p)
        assert len(lines) == 1 and "more than --max-memory-per-rank" in lines[0] and "mpirun -np 4" in lines[0], lines


def test_too_large_for_one_rank_is_computed_and_solved_on_four(large, tmp_path):
    _, ff, rec_ff = large
    assert max(rec_ff["mpi"]["rank_need_bytes"]) <= 16 * 2**20 and rec_ff["mpi"]["max_memory_per_rank"] == 16 * 2**20
    o, ref = tmp_path / "mpi.xml", tmp_path / "omp.xml"
    rec = record(radiosity("solve", SCENES / "scene2.xml", "--ff", ff, "--backend", "mpi", "--storage", "dense", *LIMIT,
                           "--tol", "1e-6", "--output", o, "--json", "--quiet", np_=4))
    record(radiosity("solve", SCENES / "scene2.xml", "--ff", ff, "--backend", "openmp", "--storage", "dense", "--tol", "1e-6",
                     "--output", ref, "--json", "--quiet"))
    assert rel_diff(radiosities(o), radiosities(ref)) <= 1e-6
    n = rec["params"]["patches"]
    assert max(rec["mpi"]["rank_need_bytes"]) <= 16 * 2**20 and rec["verify"]["agreed"] is True
    assert max(rec["mpi"]["rank_ff_bytes"]) < 4 * n * n / 3


def test_ci_case_lists_run_on_the_local_runner_and_make_the_table(tmp_path):
    """The experiments of make reproduce (mpi-formfactors, mpi-radiosity, mpi-large) at the ci preset, through
    slurm/run-local as an array task would run them, then their table and plot."""
    e = {"RESULTS": str(tmp_path / "results"), "FF_DIR": str(tmp_path / "ff"), "PRESET": "ci", "REPEAT": "1",
         "MACHINE": "mpi-test", "ANALYSIS_ALL_RECORDS": "1"}  # records of this tree, clean or not
    p = run([ROOT / "slurm" / "run-local", "mpi-formfactors", "mpi-radiosity", "mpi-large"], env=e, timeout=600)
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-2000:]
    ff = sorted((tmp_path / "ff").glob("ci-mpi-scene1-P*.ff"))
    assert len(ff) == 3 and len({f.read_bytes() for f in ff}) == 1  # P = 1, 2 and the equal-count split: one file
    p = run([sys.executable, "-m", "analysis", "tables", "ci"], env=e, cwd=ROOT, timeout=300)
    assert p.returncode == 0, p.stderr
    t = pd.read_csv(tmp_path / "results" / "mpi-test" / "tables" / "mpi_radiosity_ci.csv")
    solves = t[t["command"] == "solve"]
    assert {"strong", "weak", "large", "one process"} <= set(solves["series"])
    assert solves["agreed"].all()
    assert (tmp_path / "results" / "mpi-test" / "plots" / "mpi_radiosity_ci.png").stat().st_size > 0
