"""Radiosity across MPI ranks (issue 9), through the real program under mpirun: form factors written by P = 1..4
ranks are the serial program's bytes; --backend mpi on P = 1..4 ranks gives the single-process openmp answer within
1e-6 relative (Jacobi and BiCG-STAB, AOS and SOA, a grey scene on one channel), reading a file written by any number
of ranks; the records say what each rank held and moved; a scene one rank may not hold (--max-memory-per-rank) is
refused with exit status 2 and one line, nothing written, and computed and solved on 4 ranks."""
import json
import shutil
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pandas as pd
import pytest

from conftest import BIN, MPI_ENV, ROOT, run

SCENES = ROOT / "radiosity" / "scenes"


def mpi_built():
    if not shutil.which("mpirun"):
        return False
    p = run(["mpirun", "-np", "1", BIN / "radiosity", "solve", SCENES / "scene1.xml", "--ff", "/nonexistent",
             "--backend", "mpi"], env=MPI_ENV, timeout=60)
    return p.returncode == 2 and "cannot open" in p.stderr


pytestmark = pytest.mark.skipif(not mpi_built(), reason="bin/radiosity built without MPI, or no mpirun")

HEMICUBE = ["--hemicube", "32"]


def odd_scene(directory):
    """scene1 with one small triangle more: 1313 patches, an odd count, so that rows of 4n bytes end inside a 64-bit
    word of the checksum and the ranks' chained checksum must carry the unfinished word from rank to rank."""
    s = (SCENES / "scene1.xml").read_text()
    i = s.index("</objectdef>")
    s = s[:i] + ('<triangleset name="odd" reflectivity=".3,.3,.3"><triangle><vertex x="0" y="3" z="0"/>'
                 '<vertex x="0.5" y="3" z="0"/><vertex x="0" y="3" z="0.5"/></triangle></triangleset>\n') + s[i:]
    path = directory / "odd.xml"
    path.write_text(s)
    return path


def messages(p):
    """The program's own lines on stderr (mpirun adds its report of a non-zero exit status)."""
    return [l for l in p.stderr.splitlines() if l.startswith("radiosity:")]


def radiosity(*args, np_=None, timeout=300):
    cmd = [BIN / "radiosity", *args]
    if np_ is not None:
        return run(["mpirun", "-np", str(np_), *cmd], env=MPI_ENV, timeout=timeout)
    return run(cmd, timeout=timeout)


def record(p):
    assert p.returncode == 0, p.stderr
    lines = [l for l in p.stdout.splitlines() if l.startswith("{")]
    assert len(lines) == 1, f"one record on stdout (rank 0's), got {len(lines)}: {p.stdout[:400]}"
    return json.loads(lines[0])


def radiosities(path):
    tris = ET.parse(path).getroot().iter("triangle")
    return np.array([[float(c) for c in t.get("radiosity").split(",")] for t in tris])


def rel_diff(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """scene1 (odd patch count): the serial program's form-factor file and those of P = 1..4 ranks."""
    d = tmp_path_factory.mktemp("mpi")
    scene = odd_scene(d)
    serial = d / "serial.ff"
    rec = record(radiosity("formfactors", scene, *HEMICUBE, "-o", serial, "--json", "--quiet"))
    assert rec["params"]["patches"] % 2 == 1
    out = {"serial": (serial, rec), "scene": scene}
    for p in (1, 2, 3, 4):
        f = d / f"P{p}.ff"
        r = record(radiosity("formfactors", scene, *HEMICUBE, "-o", f, "--json", "--quiet", np_=p))
        out[p] = (f, r)
    return d, out


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


SPARSE = [("csr", "float32"), ("compressed", "float32"), ("compressed", "float16")]
RUNS = [("runs", "float32"), ("runs", "float16")]


@pytest.fixture(scope="module")
def serial_sparse(files):
    """Backend serial's answers in the sparse storages: 20 fixed Jacobi steps in float (AOS), and Jacobi and
    BiCG-STAB to 1e-6 (SOA)."""
    d, out = files
    answers = {}
    for storage, values in SPARSE + RUNS:
        for kind, args in (("steps", ["--steps", "20", "--layout", "aos", "--no-verify"]),
                           ("jacobi", ["--tol", "1e-6", "--layout", "soa"]),
                           ("bicgstab", ["--method", "bicgstab", "--tol", "1e-6", "--layout", "soa"])):
            o = d / f"serial-{storage}-{values}-{kind}.xml"
            rec = record(radiosity("solve", out["scene"], "--ff", out["serial"][0], "--backend", "serial",
                                   "--storage", storage, "--ff-precision", values, *args, "--output", o, "--json",
                                   "--quiet"))
            assert rec["params"]["storage"] == storage
            answers[storage, values, kind] = (rec, radiosities(o))
    return answers


def sparse_bytes_per_entry(storage, values):
    return (4 if values == "float32" else 2) + (4 if storage == "csr" else 2)


@pytest.mark.parametrize("ranks", [1, 2, 3, 4])
@pytest.mark.parametrize("storage,values", SPARSE)
def test_mpi_sparse_storage_gives_serial_answer_rows_balanced_by_entries(files, serial_sparse, ranks, storage, values,
                                                                          tmp_path):
    """Each rank builds its rows in csr or compressed from its rows of the dense file and runs the CPU's sparse
    product on them: fixed Jacobi steps are serial's bits (a row's sum is the same code on any rank, the float16
    scale every rank's largest value); to a tolerance, within 1e-6 (the dots add in another order). The ranks' rows
    are balanced by entries, and the record says the bytes of F each holds in that storage."""
    _, out = files
    writer = {1: 2, 2: 4, 3: 1, 4: 3}[ranks]
    o = tmp_path / "steps.xml"
    rec = record(radiosity("solve", out["scene"], "--ff", out[writer][0], "--backend", "mpi", "--storage", storage,
                           "--ff-precision", values, "--steps", "20", "--layout", "aos", "--no-verify", "--output", o,
                           "--json", "--quiet", np_=ranks))
    assert np.array_equal(radiosities(o), serial_sparse[storage, values, "steps"][1])
    assert rec["params"]["storage"] == storage
    n = rec["params"]["patches"]
    mpi = rec["mpi"]
    rows, held = mpi["rank_rows"], mpi["rank_ff_bytes"]
    assert sum(rows) == n and len(held) == ranks
    entries = [(b - 8 * (n + 1)) / sparse_bytes_per_entry(storage, values) for b in held]
    assert all(e == int(e) and e >= 0 for e in entries), entries
    # what one product reads on all ranks together: serial's entries of the same storage
    assert sum(entries) * sparse_bytes_per_entry(storage, values) + 8 * (n + 1) == pytest.approx(
        serial_sparse[storage, values, "steps"][0]["perf"]["matrix_bytes"])
    # balanced by entries (a row's cost: its entries and 8, csr_kernels.hpp), each block within one row of its share
    cost = [e + 8 * r for e, r in zip(entries, rows)]
    assert max(cost) <= sum(cost) / ranks + n + 8, (cost, rows)
    for method, layout in (("jacobi", "soa"), ("bicgstab", "soa")):
        o = tmp_path / f"{method}.xml"
        rec = record(radiosity("solve", out["scene"], "--ff", out[writer][0], "--backend", "mpi", "--storage", storage,
                               "--ff-precision", values, "--method", method, "--tol", "1e-6", "--layout", layout,
                               "--output", o, "--json", "--quiet", np_=ranks))
        ref, b_ref = serial_sparse[storage, values, method]
        assert rel_diff(radiosities(o), b_ref) <= 1e-6
        assert rec["result"]["status"] == "converged" and rec["verify"]["agreed"] is True


def runs_counts(held_32, held_16, n):
    """A runs matrix's stored values e and runs r from its bytes in float32 (4e + 4r + 16 (n + 1)) and in float16
    (2e + 4r + 16 (n + 1)): the same rows, the same runs."""
    e = (held_32 - held_16) / 2
    return e, (held_16 - 16 * (n + 1) - 2 * e) / 4


@pytest.mark.parametrize("ranks", [1, 2, 3, 4])
def test_mpi_runs_storage_gives_serial_answer_rows_balanced_by_cost(files, serial_sparse, ranks, tmp_path):
    """Each rank builds its rows in runs storage from its rows of the dense file (row and run starts for every row,
    its own rows' runs as the whole matrix's) and runs the CPU's runs product on them: a row's sum depends only on
    its runs, so fixed Jacobi steps are serial's bits in float32 and float16 (the float16 scale every rank's largest
    value); to a tolerance, within 1e-6. The ranks' rows are balanced by their cost (stored values, 8 a run, 8 a
    row), and the bytes each holds add up to serial's."""
    _, out = files
    writer = {1: 4, 2: 3, 3: 2, 4: 1}[ranks]
    held = {}
    for _, values in RUNS:
        o = tmp_path / f"steps-{values}.xml"
        rec = record(radiosity("solve", out["scene"], "--ff", out[writer][0], "--backend", "mpi", "--storage", "runs",
                               "--ff-precision", values, "--steps", "20", "--layout", "aos", "--no-verify",
                               "--output", o, "--json", "--quiet", np_=ranks))
        assert np.array_equal(radiosities(o), serial_sparse["runs", values, "steps"][1]), values
        assert rec["params"]["storage"] == "runs" and rec["params"]["ff_precision"] == values
        held[values] = rec["mpi"]["rank_ff_bytes"]
        rows = rec["mpi"]["rank_rows"]
    n = rec["params"]["patches"]
    assert sum(rows) == n and len(rows) == ranks
    counts = [runs_counts(a, b, n) for a, b in zip(held["float32"], held["float16"])]
    assert all(e == int(e) and r == int(r) and e >= 0 and r >= 0 for e, r in counts), counts
    # what one product reads on all ranks together: serial's runs matrix
    for values, v in (("float32", 4), ("float16", 2)):
        assert sum(e * v + 4 * r for e, r in counts) + 16 * (n + 1) == pytest.approx(
            serial_sparse["runs", values, "steps"][0]["perf"]["matrix_bytes"])
    # each block within one row of its share (a row: at most n values in at most n/6 + 1 runs: gaps above 4 zeros)
    cost = [e + 8 * r + 8 * rows_r for (e, r), rows_r in zip(counts, rows)]
    assert max(cost) <= sum(cost) / ranks + n + 8 * (n // 6 + 1) + 8, (cost, rows)
    for method in ("jacobi", "bicgstab"):
        o = tmp_path / f"{method}.xml"
        rec = record(radiosity("solve", out["scene"], "--ff", out[writer][0], "--backend", "mpi", "--storage", "runs",
                               "--ff-precision", "float16", "--method", method, "--tol", "1e-6", "--layout", "soa",
                               "--output", o, "--json", "--quiet", np_=ranks))
        assert rel_diff(radiosities(o), serial_sparse["runs", "float16", method][1]) <= 1e-6
        assert rec["result"]["status"] == "converged" and rec["verify"]["agreed"] is True


def test_mpi_auto_chooses_alike_on_any_number_of_ranks(files):
    """--storage auto on mpi chooses from every rank's counts together (runs counted in each rank's rows and summed):
    the serial run's storage on 1 and 3 ranks, on scene1 (36% of F non-zero) runs, as the summary says."""
    _, out = files
    picks = []
    for np_, backend in ((None, "serial"), (1, "mpi"), (3, "mpi")):
        p = radiosity("solve", out["scene"], "--ff", out["serial"][0], "--backend", backend, "--steps", "2",
                      "--no-verify", "--json", np_=np_)
        rec = record(p)
        assert rec["params"]["storage_requested"] == "auto"
        picks.append(rec["params"]["storage"])
        assert f"form factors: {picks[-1]} (auto: the fewest bytes per step" in p.stdout, p.stdout
    assert picks == ["runs"] * 3, picks


@pytest.mark.parametrize("storage,values", [("csr", "float32"), ("runs", "float32"), ("runs", "float16")])
def test_mpi_memory_check_counts_the_sparse_storage(files, tmp_path, storage, values):
    """--max-memory-per-rank with csr or runs: what a rank needs (the record's rank_need_bytes, counted before the
    matrix is built) is its dense rows while its matrix is built, that matrix (the bytes it then holds:
    rank_ff_bytes) and the vectors; a byte less is refused on every rank with one line, exit 2."""
    _, out = files
    args = ["solve", out["scene"], "--ff", out["serial"][0], "--backend", "mpi", "--storage", storage,
            "--ff-precision", values, "--steps", "2", "--no-verify", "--json", "--quiet"]
    mpi = record(radiosity(*args, np_=2))["mpi"]
    need = mpi["rank_need_bytes"]
    n = sum(mpi["rank_rows"])
    vectors = (2 * (8 + 2) * 3 * 8 + 8 * 3 * 8) * n  # solve_load.cpp's vector_bytes
    assert need == [f + 4 * r * n + vectors for f, r in zip(mpi["rank_ff_bytes"], mpi["rank_rows"])], mpi
    ok = record(radiosity(*args, "--max-memory-per-rank", str(int(max(need))), np_=2))
    assert ok["mpi"]["rank_need_bytes"] == need
    p = radiosity(*args, "--max-memory-per-rank", str(int(max(need)) - 1), np_=2)
    assert p.returncode == 2, p.stderr
    lines = messages(p)
    assert len(lines) == 1 and f"in {storage} {values}" in lines[0], lines
    assert "more than --max-memory-per-rank" in lines[0], lines


def test_mpi_refuses_a_sparse_file(files, tmp_path):
    _, out = files
    f = tmp_path / "csr.ff"
    record(radiosity("formfactors", out["scene"], *HEMICUBE, "-o", f, "--storage", "csr", "--json", "--quiet"))
    p = radiosity("solve", out["scene"], "--ff", f, "--backend", "mpi", "--steps", "2", np_=2)
    assert p.returncode == 2 and "each rank builds its rows' storage" in p.stderr, p.stderr


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
