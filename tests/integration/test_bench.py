"""What `make bench` runs, on small problems (correctness, records and refusals only; the timings are the bench's):
bin/stream, the Python peers (SciPy CG, NumPy Jacobi) against our programs, and the table built from records."""
import json
import os
import subprocess
import sys

import pytest

from conftest import BIN, ROOT, run

SCENES = ROOT / "radiosity" / "scenes"
PEERS = [sys.executable, "-m", "bench.peers"]


def peer(*args, env=None):
    p = run([*PEERS, *args], env=env, cwd=ROOT, timeout=300)
    rec = json.loads([l for l in p.stdout.splitlines() if l.startswith("{")][-1]) if "--json" in args and \
        p.returncode == 0 else None
    return p, rec


def test_stream_measures_and_records(tmp_path):
    path = tmp_path / "s.jsonl"
    p = run([BIN / "stream", "--size", 1 << 16, "--trials", 3, "--threads", 2, "--record", path])
    assert p.returncode == 0, p.stderr
    assert "triad" in p.stdout and "read" in p.stdout
    rec = json.loads(path.read_text())
    assert rec["schema"] == "hpcgi-record/1" and rec["app"] == "stream" and rec["result"]["valid"] is True
    assert rec["params"]["threads"] == 2 and rec["perf"]["triad_bytes"] == 24 * (1 << 16)
    assert rec["perf"]["triad_GBps"] >= rec["perf"]["triad_median_GBps"] > 0


@pytest.mark.parametrize("prefetch", [0, 64, 4096])
def test_stream_read_sweep_sums_every_element_with_and_without_prefetch(tmp_path, prefetch):
    """Issue 37: the read sweep asks for its lines ahead (--read-prefetch bytes, 0: none); bin/stream checks the sum
    of every word it read (b's, which the triad only reads) and exits 3 where it is wrong, here on a size whose
    blocks end in partial lines."""
    path = tmp_path / "s.jsonl"
    p = run([BIN / "stream", "--size", (1 << 16) + 13, "--trials", 2, "--threads", 2, "--read-prefetch", prefetch,
             "--record", path])
    assert p.returncode == 0, p.stderr
    rec = json.loads(path.read_text())
    assert rec["result"]["valid"] is True
    assert rec["params"]["read_sweep"] == {"streams_per_thread": 4, "prefetch_bytes": prefetch}


@pytest.mark.parametrize("args", [["--size", "0"], ["--trials", "0"], ["--threads", "x"], ["--bogus"],
                                  ["--read-prefetch", "-1"]])
def test_stream_bad_arguments_exit_2_with_one_line(args):
    p = run([BIN / "stream", *args])
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr


@pytest.mark.parametrize("n,cap", [(32, None), (64, 20)])
def test_scipy_cg_takes_our_iterations_on_our_problem(tmp_path, n, cap):
    extra = ["--max-iter", str(cap)] if cap else []
    # ours stopped by --max-iter is no answer (exit 4), with its record
    mine = tmp_path / "ours.jsonl"
    p = run([BIN / "poisson", "--n", n, "--backend", "serial", "--quiet", "--record", mine, *extra])
    assert p.returncode == (4 if cap else 0), p.stderr
    ours = json.loads(mine.read_text())
    path = tmp_path / "p.jsonl"
    p = run([*PEERS, "scipy-cg", "--n", n, "--threads", 1, "--quiet", "--record", path, *extra], cwd=ROOT)
    # the peer stopped by --max-iter is no answer as ours is: exit 4, the record written with its status and reason
    assert p.returncode == (4 if cap else 0), p.stderr
    rec = json.loads(path.read_text())
    assert rec["result"]["exit_status"] == ours["result"]["exit_status"] == (4 if cap else 0)
    assert (rec["result"]["exit_reason"] is None) == (cap is None)
    assert cap is None or f"(--max-iter {cap})" in p.stderr and len(p.stderr.strip().splitlines()) == 1
    assert rec["schema"] == "hpcgi-record/1" and rec["app"] == "peer" and rec["params"]["peer"] == "scipy-cg"
    assert rec["provenance"]["libraries"]["scipy"] and rec["provenance"]["git_commit"]
    assert rec["result"]["iterations"] == ours["result"]["iterations"]
    assert rec["result"]["status"] == ours["result"]["status"]
    assert rec["result"]["error_inf"] == pytest.approx(ours["result"]["error_inf"], rel=1e-6)


def test_peers_set_the_blas_threads_in_their_record():
    p, rec = peer("scipy-cg", "--n", "8", "--threads", "3", "--json", "--quiet")
    assert p.returncode == 0, p.stderr
    assert rec["provenance"]["env"]["OPENBLAS_NUM_THREADS"] == "3" and rec["params"]["threads"] == 3


@pytest.fixture(scope="module")
def scene1(tmp_path_factory):
    """scene1's form factors at a small hemicube and our 4 Jacobi steps written out."""
    d = tmp_path_factory.mktemp("scene1")
    ff, solved = d / "s.ff", d / "s.xml"
    for args in (["formfactors", SCENES / "scene1.xml", "-o", ff, "--hemicube", "32", "--quiet"],
                 ["solve", SCENES / "scene1.xml", "--ff", ff, "--steps", "4", "--output", solved, "--quiet"]):
        p = run([BIN / "radiosity", *args])
        assert p.returncode == 0, p.stderr
    return ff, solved


@pytest.mark.parametrize("way", ["gemm", "gemv"])
def test_numpy_jacobi_agrees_with_our_steps(scene1, way):
    ff, solved = scene1
    p, rec = peer("numpy-jacobi", str(SCENES / "scene1.xml"), "--ff", str(ff), "--solved", str(solved), "--steps",
                  "4", "--way", way, "--threads", "2", "--json", "--quiet")
    assert p.returncode == 0, p.stderr
    assert rec["verify"]["agreed"] and rec["verify"]["max_rel_diff"] < 1e-5
    assert rec["params"]["patches"] == 1312 and rec["perf"]["matrix_passes"] == (4 if way == "gemm" else 12)


def test_numpy_jacobi_with_other_steps_disagrees_and_exits_5(scene1):
    ff, solved = scene1
    p, _ = peer("numpy-jacobi", str(SCENES / "scene1.xml"), "--ff", str(ff), "--solved", str(solved), "--steps", "5",
                "--quiet")
    assert p.returncode == 5 and "disagreed with its float64 check" in p.stderr, p.stderr


def test_numpy_jacobi_refuses_foreign_form_factors(tmp_path, scene1):
    ff, solved = scene1
    other = tmp_path / "box.ff"
    assert run([BIN / "radiosity", "formfactors", SCENES / "closed_box.xml", "-o", other, "--hemicube", "8",
                "--quiet"]).returncode == 0
    bad = tmp_path / "bad.ff"
    bad.write_bytes(b"not a form-factor file at all, but long enough to hold a header of 72 bytes........")
    for f in (other, bad, tmp_path / "missing.ff"):
        p, _ = peer("numpy-jacobi", str(SCENES / "scene1.xml"), "--ff", str(f), "--solved", str(solved), "--quiet")
        assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr


@pytest.mark.parametrize("args", [["scipy-cg", "--n", "0"], ["scipy-cg", "--tol", "nan"], ["nonsense"], [],
                                  ["numpy-jacobi", "x.xml"]])
def test_peer_bad_arguments_exit_2_with_one_line(args):
    p, _ = peer(*args)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert p.stderr.startswith("peers:")


def test_peers_help_exits_0():
    p, _ = peer("--help")
    assert p.returncode == 0 and "scipy-cg" in p.stdout and "numpy-jacobi" in p.stdout


def test_bench_table_from_records(tmp_path):
    """analysis.bench on a few records: ratios against the triad limit and the peers, targets judged."""
    env = dict(os.environ, RESULTS=str(tmp_path / "results"), MACHINE="bench-test",
               ANALYSIS_ALL_RECORDS="1")  # records of this tree, clean or not
    res = tmp_path / "results" / "bench-test"
    p = run([BIN / "stream", "--size", 1 << 16, "--trials", 2, "--record", res / "bench-stream/quick.jsonl"])
    assert p.returncode == 0, p.stderr
    for args in (["--n", "2048", "--variant", "onesweep"], ["--n", "2048", "--variant", "classic"]):
        p = run([BIN / "poisson", "--backend", "openmp", "--steps", "3", "--quiet", "--record",
                 res / "bench-cg/quick.jsonl", *args])
        assert p.returncode == 0, p.stderr
    p, _ = peer("scipy-cg", "--n", "2048", "--max-iter", "3", "--quiet", "--record", str(res / "bench-cg/quick.jsonl"))
    assert p.returncode == 4, p.stderr
    p = subprocess.run([sys.executable, "-m", "analysis.bench", "quick"], cwd=ROOT, env=env, capture_output=True,
                       text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    table = (res / "tables" / "bench_quick.md").read_text()
    assert "CPU timings" in table and "openmp onesweep, 6 vectors" in table and "SciPy" in table
    assert "limit: STREAM triad" in table
    assert "CG N=2048 (openmp" in table and "faster per iteration than SciPy" in table


@pytest.mark.parametrize("storage,values", [("dense", "float32"), ("csr", "float32"), ("compressed", "float16"),
                                            ("runs", "float16")])
def test_read_sweeps_read_the_bytes_a_product_reads(tmp_path, scene1, storage, values):
    """Issue 37: --read-sweeps K, after the steps, K read-only sweeps over F's own arrays on the same threads (the
    product's byte limit in the same process, each sweep's sum checked): the sparse storages' bytes are the product's
    (perf.matrix_bytes), dense's all n rows; best <= median, GB/s from the best."""
    ff, _ = scene1
    path = tmp_path / "r.jsonl"
    p = run([BIN / "radiosity", "solve", SCENES / "scene1.xml", "--ff", ff, "--steps", "4", "--storage", storage,
             "--ff-precision", values, "--threads", "2", "--no-verify", "--read-sweeps", "3", "--record", path])
    assert p.returncode == 0, p.stderr
    rec = json.loads(path.read_text())
    perf, t, n = rec["perf"], rec["times_s"], rec["params"]["patches"]
    assert perf["read_sweep_bytes"] == (4.0 * n * n if storage == "dense" else perf["matrix_bytes"])
    assert perf["read_sweeps"] == 3 and 0 < t["read_sweep_best"] <= t["read_sweep_median"]
    assert perf["read_sweep_GBps"] == pytest.approx(perf["read_sweep_bytes"] / t["read_sweep_best"] / 1e9)
    assert "read sweeps of F's arrays" in p.stdout


@pytest.mark.parametrize("args", [["--read-sweeps", "-1"], ["--read-sweeps", "2", "--backend", "original"]])
def test_read_sweeps_refused_where_they_cannot_run(scene1, args):
    """Negative counts, and the backends that do not sweep their matrix: exit 2, one line, before the solve."""
    ff, _ = scene1
    p = run([BIN / "radiosity", "solve", SCENES / "scene1.xml", "--ff", ff, "--steps", "4", "--no-verify", *args])
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert "read-sweeps" in p.stderr or "sweep" in p.stderr


def test_bench_sparse_table_sets_each_storage_against_its_bytes(tmp_path, scene1):
    """analysis.bench on bench-sparse records: per storage its bytes per step, its time over those bytes at the
    read sweep next to it, and bytes per entry (8 for csr float32, 4 + row starts for compressed float16, runs' own)."""
    ff, _ = scene1
    env = dict(os.environ, RESULTS=str(tmp_path / "results"), MACHINE="bench-test",
               ANALYSIS_ALL_RECORDS="1")  # records of this tree, clean or not
    res = tmp_path / "results" / "bench-test"
    for storage, values in (("dense", "float32"), ("csr", "float32"), ("compressed", "float16"), ("runs", "float16")):
        p = run([BIN / "stream", "--size", 1 << 16, "--trials", 2, "--record", res / "bench-stream/quick.jsonl"])
        assert p.returncode == 0, p.stderr
        p = run([BIN / "radiosity", "solve", SCENES / "scene1.xml", "--ff", ff, "--steps", "8", "--storage", storage,
                 "--ff-precision", values, "--no-verify", "--quiet", "--record", res / "bench-sparse/quick.jsonl"])
        assert p.returncode == 0, p.stderr
    p = subprocess.run([sys.executable, "-m", "analysis.bench", "quick"], cwd=ROOT, env=env, capture_output=True,
                       text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    table = (res / "tables" / "bench_quick.md").read_text()
    assert "Sparse form factors: a Jacobi step by storage" in table
    cells = [[c.strip() for c in l.split("|")] for l in table.splitlines()]
    assert any("csr float32" in c and "8" in c for c in cells), table
    assert any("compressed float16" in l for l in table.splitlines()) and "time / its limit" in table
    assert any("runs float16" in l for l in table.splitlines()), table


def test_bench_sparse_targets_judge_every_sparse_storage_on_room3(tmp_path, scene1):
    """Issue 37: on room3, every sparse storage's step against its bytes at its own read sweep where its records
    have one (runs here), else at bin/stream's read sweep next to it (csr here), <= 1.3x, the verdict the ratio's;
    a storage's records with the sweep supersede those without. Real records of scene1, named room3 (the targets are
    room3's)."""
    ff, _ = scene1
    env = dict(os.environ, RESULTS=str(tmp_path / "results"), MACHINE="bench-test", ANALYSIS_ALL_RECORDS="1")
    res = tmp_path / "results" / "bench-test"
    for storage, values, sweeps in (("dense", "float32", []), ("csr", "float32", []), ("runs", "float16", []),
                                    ("runs", "float16", ["--read-sweeps", "4"])):
        p = run([BIN / "stream", "--size", 1 << 16, "--trials", 2, "--record", res / "bench-stream/quick.jsonl"])
        assert p.returncode == 0, p.stderr
        p = run([BIN / "radiosity", "solve", SCENES / "scene1.xml", "--ff", ff, "--steps", "8", "--storage", storage,
                 "--ff-precision", values, "--no-verify", "--quiet", *sweeps, "--record",
                 res / "bench-sparse/quick.jsonl"])
        assert p.returncode == 0, p.stderr
    path = res / "bench-sparse/quick.jsonl"
    recs = [json.loads(l) for l in path.read_text().splitlines()]
    for r in recs:
        r["params"]["scene"] = "/somewhere/room3.xml"
    path.write_text("".join(json.dumps(r) + "\n" for r in recs))
    p = subprocess.run([sys.executable, "-m", "analysis.bench", "quick"], cwd=ROOT, env=env, capture_output=True,
                       text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    table = (res / "tables" / "bench_quick.md").read_text()
    for storage, where in (("csr float32", "at the read sweep next to it"), ("runs float16", "at its own read sweep")):
        line = next(l for l in table.splitlines() if l.lstrip("- ").startswith(f"{storage} room3: ") and "read sweep" in l)
        low, high = (float(x) for x in line.split("GB/s): ")[1].split(" [")[1].split("]")[0].split(", "))
        # decided by the one rule (analysis/verdict.py) on the interval shown
        from analysis import claims, verdict
        assert where in line and "target <= 1.3x" in line, line
        assert line.endswith(": " + verdict.decide(low, high, "less", 1.3, claims.margin())), line
    runs = next(l for l in table.splitlines() if "| runs float16 |" in l)
    assert runs.rstrip(" |").endswith("| 1"), runs  # the one record with its own sweep, not both
    assert not any(l.lstrip("- ").startswith("dense float32 room3: ") for l in table.splitlines()), table


def test_bench_refuses_an_unknown_case_list_before_running_anything(tmp_path):
    """make bench BENCH=...: a list that does not exist is refused with exit 2 before any case or measurement."""
    env = {**os.environ, "BENCH": "bench-sparse bench-nonesuch", "RESULTS": str(tmp_path), "RRV_SCENES": str(tmp_path)}
    p = run([ROOT / "slurm" / "bench"], env=env, cwd=ROOT, timeout=60)
    assert p.returncode == 2, p.stdout + p.stderr
    assert "bench-nonesuch" in p.stderr
    assert not any(tmp_path.rglob("*.jsonl"))
