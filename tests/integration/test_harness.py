"""The study harness end to end: the local runner, resuming after a killed task, and a real single-node Slurm
running a job array (munge, slurmctld and slurmd from Debian's packages, started by slurm/local-cluster)."""
import json
import os
import shutil
import signal
import subprocess
import time
from collections import Counter
from pathlib import Path

import pandas as pd
import pytest

from analysis.records import newest
from conftest import ROOT, run


MACHINE = "ci-test-machine"


def env(tmp_path, **kw):
    return {"RESULTS": str(tmp_path / "results"), "FF_DIR": str(tmp_path / "ff"), "PRESET": "ci", "MACHINE": MACHINE,
            **kw}


def mdir(tmp_path):
    """The test machine's folder of records."""
    return tmp_path / "results" / MACHINE


def records(tmp_path, exp):
    f = mdir(tmp_path) / exp / "ci.jsonl"
    return [json.loads(line) for line in f.read_text().splitlines()] if f.exists() else []


def cases(exp):
    lines = (ROOT / "slurm" / "cases" / "ci" / f"{exp}.txt").read_text().splitlines()
    return [l for l in lines if l.strip() and not l.startswith("#")]


def check_once_each(tmp_path, exp, repeat):
    """Every (case, repeat) recorded exactly once, every line a valid record; GPU cases noted as skipped instead."""
    recs = records(tmp_path, exp)
    keys = Counter((r["provenance"]["env"]["HPCGI_CASE"], r["provenance"]["env"]["HPCGI_REPEAT"]) for r in recs)
    assert all(c == 1 for c in keys.values()), keys
    skipped_file = mdir(tmp_path) / exp / "ci.skipped"
    skipped = {json.loads(l)["case"] for l in skipped_file.read_text().splitlines()} if skipped_file.exists() else set()
    done = {c for c, _ in keys}
    assert len(done | skipped) == len(cases(exp))
    assert all(sum(1 for (c, _) in keys if c == case) == repeat for case in done)
    return recs


def test_local_runner_and_dry_run(tmp_path):
    e = env(tmp_path, REPEAT="2")
    p = run([ROOT / "slurm" / "run-local", "table41"], env={**e, "DRY_RUN": "1"})
    assert p.returncode == 0 and "would run" in p.stdout and not (tmp_path / "results").exists()
    p = run([ROOT / "slurm" / "run-local", "table41"], env=e, timeout=600)
    assert p.returncode == 0, p.stderr
    check_once_each(tmp_path, "table41", 2)
    # a re-run runs nothing that is recorded; a GPU case skipped for want of a GPU is tried again (it may land on
    # a GPU node next time), so only those can be missing
    again = run([ROOT / "slurm" / "run-local", "table41"], env=e)
    ran = [l for l in again.stdout.splitlines() if " repeat " in l and "already recorded" not in l]
    assert all(any(b in l for b in ("cublas1", "cublas2", "cuda")) for l in ran), ran
    missing = run([ROOT / "slurm" / "missing", "table41"], env=e).stdout.strip()
    gpu = [str(i) for i, c in enumerate(cases("table41")) if "--backend cu" in c]
    assert missing == ",".join(gpu)


def test_killed_runner_then_rerun_leaves_valid_records_and_no_duplicates(tmp_path):
    e = dict(os.environ, **env(tmp_path, REPEAT="20"))
    p = subprocess.Popen([ROOT / "slurm" / "run-local", "table41"], env=e, cwd=ROOT, start_new_session=True,
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    f = mdir(tmp_path) / "table41" / "ci.jsonl"
    deadline = time.time() + 120
    while time.time() < deadline and (not f.exists() or len(f.read_text().splitlines()) < 7):
        time.sleep(0.05)
    os.killpg(p.pid, signal.SIGKILL)  # the runner, run-case and the program in flight, all at once
    p.wait()
    partial = records(tmp_path, "table41")  # every line parses
    assert 7 <= len(partial) < 20 * len(cases("table41"))
    missing = run([ROOT / "slurm" / "missing", "table41"], env=env(tmp_path, REPEAT="20")).stdout.strip()
    assert missing.split(",")[0] in [str(i) for i, c in enumerate(cases("table41")) if "--backend cu" not in c]
    assert run([ROOT / "slurm" / "run-local", "table41"], env=env(tmp_path, REPEAT="20"), timeout=900).returncode == 0
    check_once_each(tmp_path, "table41", 20)


slurm_ready = pytest.mark.skipif(
    os.geteuid() != 0 or not shutil.which("slurmctld") or not shutil.which("sbatch"),
    reason="a single-node Slurm needs root and Debian's slurmctld/slurmd/munge (make deps)")


@pytest.fixture
def cluster():
    p = run([ROOT / "slurm" / "local-cluster", "start"], timeout=120)
    assert p.returncode == 0, p.stdout + p.stderr
    yield
    run([ROOT / "slurm" / "local-cluster", "stop"], timeout=60)


@slurm_ready
def test_job_arrays_under_slurm_then_make_plots(tmp_path, cluster):
    # ANALYSIS_ALL_RECORDS=1: this test's own runs count, disturbed or not (on a busy machine most are flagged, and
    # a table of none is no table: issue 48); what it checks is that every cell with a case gets a value
    e = env(tmp_path, REPEAT="1", WAIT="1", GPUS="0", LOG_DIR=str(tmp_path / "logs"), ANALYSIS_ALL_RECORDS="1")
    p = run([ROOT / "slurm" / "submit", "formfactors", "table41", "table42", "--ntasks=2", "--cpus-per-task=1"],
            env=e, timeout=900)
    assert p.returncode == 0, p.stdout + p.stderr
    assert "submit: formfactors" in p.stdout and "aggregate" in p.stdout
    for exp in ("formfactors", "table41", "table42"):
        recs = check_once_each(tmp_path, exp, 1)
        assert all(r["provenance"]["env"].get("SLURM_ARRAY_JOB_ID") for r in recs), "records must come from the array"
    # the aggregation job ran make plots after the arrays: every table cell that has a case has a value
    tables = mdir(tmp_path) / "tables"
    t41 = pd.read_csv(tables / "table41_ci.csv")
    assert set(t41["n"]) == {16, 32} and t41["median"].notna().all()
    assert {"p1", "p2", "openmp"} <= set(t41["column"])
    t42 = pd.read_csv(tables / "table42_ci.csv")
    assert len(t42) == len(cases("table42")) and t42["median"].notna().all()  # one scene: a row per method
    md = (tables / "table41_ci.md").read_text()
    assert "No GPU on this machine" in md
    assert (mdir(tmp_path) / "plots" / "figure41_ci.png").stat().st_size > 0
    assert (tmp_path / "results" / "report" / MACHINE / "REPORT-ci.md").exists()
    assert len(list((tmp_path / "logs").glob("aggregate_*.out"))) == 1


def test_task_past_its_time_limit_leaves_no_record_and_says_so(tmp_path):
    # Slurm ends a task past its time limit with SIGTERM, then SIGKILL; `timeout` does the same here, to the
    # quick preset's N = 1024 run on one MPI rank (seconds long).
    e = env(tmp_path, REPEAT="1", PRESET="quick")
    f = mdir(tmp_path) / "table41" / "quick.jsonl"
    p = run(["timeout", "-s", "TERM", "0.5", ROOT / "slurm" / "run-case", "table41", "4"], env=e)
    assert p.returncode != 0 and not f.exists()
    p = run([ROOT / "slurm" / "run-case", "table41", "4"], env=e)
    assert p.returncode == 0 and len(f.read_text().splitlines()) == 1


def descendants(pid):
    """Every process below pid (from ps), so a test kills its own processes and nobody else's."""
    rows = [l.split() for l in subprocess.run(["ps", "-eo", "pid=,ppid=,args="], capture_output=True,
                                               text=True).stdout.splitlines()]
    kids, todo = [], [pid]
    while todo:
        p = todo.pop()
        for r in rows:
            if int(r[1]) == p:
                kids.append((int(r[0]), " ".join(r[2:])))
                todo.append(int(r[0]))
    return kids


def test_program_killed_by_a_signal_is_named(tmp_path):
    # The solver dies (as under the OOM killer), not the runner: the runner says so and records nothing.
    e = env(tmp_path, REPEAT="1", PRESET="quick")
    p = subprocess.Popen([ROOT / "slurm" / "run-case", "table41", "4"], env=dict(os.environ, **e), cwd=ROOT,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 30
    while time.time() < deadline:
        solvers = [pid for pid, args in descendants(p.pid) if args.startswith("bin/poisson")]
        if solvers:
            time.sleep(0.3)
            for pid in solvers:
                os.kill(pid, signal.SIGKILL)
            break
        time.sleep(0.01)
    out, err = p.communicate(timeout=60)
    assert p.returncode != 0, out
    assert "repeat 0" in err and ("killed by signal" in err or "failed" in err), err
    assert not (mdir(tmp_path) / "table41" / "quick.jsonl").exists()


def test_full_disk_while_writing_a_record_leaves_the_file_valid(tmp_path):
    # A file-size limit makes the record's write fail as a full disk would (EFBIG instead of ENOSPC). Case 4 is
    # a single-process one: mpirun itself cannot start under such a limit.
    e = env(tmp_path, REPEAT="3")
    assert run([ROOT / "slurm" / "run-case", "table41", "4"], env={**e, "REPEAT": "1"}).returncode == 0
    f = mdir(tmp_path) / "table41" / "ci.jsonl"
    size_kb = f.stat().st_size // 1024 + 1
    p = run(["bash", "-c", f"trap '' XFSZ; ulimit -f {size_kb}; exec {ROOT}/slurm/run-case table41 4"], env=e)
    assert p.returncode != 0 and "cannot append record" in p.stderr, p.stderr
    assert len(records(tmp_path, "table41")) >= 1  # every line still parses: the short write was cut back
    assert f.read_text().endswith("\n")
    assert run([ROOT / "slurm" / "run-case", "table41", "4"], env=e).returncode == 0
    assert len(records(tmp_path, "table41")) == 3


def test_form_factor_file_deleted_between_tasks(tmp_path):
    e = env(tmp_path, REPEAT="1")
    assert run([ROOT / "slurm" / "run-local", "formfactors"], env=e).returncode == 0
    (tmp_path / "ff" / "ci-scene1.ff").unlink()
    p = run([ROOT / "slurm" / "run-case", "table42", "0"], env=e)
    assert p.returncode == 2 and "ci-scene1.ff" in p.stderr, p.stderr
    assert records(tmp_path, "table42") == []
    # a re-run of both finds the file missing, makes it again, then finishes the solve
    assert run([ROOT / "slurm" / "run-local", "formfactors", "table42"], env=e).returncode == 0
    # scene1's form factors twice (ci's coarse room3, when RRV's scenes are here, once)
    assert sum("scene1.xml" in r["argv"][2] for r in records(tmp_path, "formfactors")) == 2
    assert len(records(tmp_path, "table42")) == len(cases("table42"))


def test_audit_makes_the_form_factors_a_case_reads(tmp_path):
    """make audit on a checkout without build/ff: the recorded case that wrote the file makes it again first."""
    e = env(tmp_path, REPEAT="1")
    assert run([ROOT / "slurm" / "run-local", "formfactors"], env=e).returncode == 0
    assert run([ROOT / "slurm" / "run-case", "table42", "0"], env=e).returncode == 0
    for f in (tmp_path / "ff").glob("*.ff"):
        f.unlink()
    p = run([ROOT / "slurm" / "audit", "ci", "--sample", "100"], env=e, cwd=ROOT)
    assert p.returncode == 0, p.stdout + p.stderr
    assert "audit: making" in p.stderr and "ci-scene1.ff" in p.stderr, p.stderr
    assert (tmp_path / "ff" / "ci-scene1.ff").exists()


def test_each_case_is_told_by_its_newest_commit():
    """A case re-run by newer code (more repeats) is told by those records; the older stay as history; records
    made outside the runner (no case) are all kept."""
    df = pd.DataFrame({
        "provenance.env.HPCGI_CASE": ["a", "a", "a", "b", None, None],
        "provenance.git_commit": ["old", "old", "new", "old", "x", "y"],
        "provenance.utc": ["2026-01-01T00:00:00Z", "2026-01-01T00:00:01Z", "2026-02-01T00:00:00Z",
                           "2026-01-01T00:00:02Z", "2026-01-01T00:00:03Z", "2026-03-01T00:00:00Z"],
        "t": [1, 2, 3, 4, 5, 6]})
    assert sorted(newest(df)["t"]) == [3, 4, 5, 6]


def test_a_case_that_is_no_answer_is_recorded_with_its_status_and_not_run_again(tmp_path):
    """A run that ends with exit status 3, 4 or 5 and wrote its record is done with that status: the case is not
    run again (nor its other repeats), run-case exits 0, the summary lists it, missing and a re-run leave it alone."""
    preset = f"test-noanswer-{os.getpid()}"
    folder = ROOT / "slurm" / "cases" / preset
    folder.mkdir()
    try:
        (folder / "noanswer.txt").write_text("# repeat: 2\nbin/poisson --n 64 --max-iter 3\nbin/poisson --n 16\n")
        e = env(tmp_path, PRESET=preset, REPEAT="2")
        p = run([ROOT / "slurm" / "run-local", "noanswer"], env=e, timeout=300)
        assert p.returncode == 0, p.stdout + p.stderr
        assert "no answer (exit 4), recorded with that status" in p.stderr, p.stderr
        assert "2 cases run (1 no answer)" in p.stdout, p.stdout
        assert "no answer, recorded with their exit status (1): noanswer/0 (exit 4)" in p.stdout, p.stdout
        recs = [json.loads(l) for l in (mdir(tmp_path) / "noanswer" / f"{preset}.jsonl").read_text().splitlines()]
        # in rounds (the timing protocol) a case leaves at its first run that is no answer: it would be the same
        # answer again; the other case runs its 2 rounds
        assert sorted(r["result"]["exit_status"] for r in recs) == [0, 0, 4]
        assert run([ROOT / "slurm" / "missing", "noanswer"], env=e).stdout.strip() == ""
        again = run([ROOT / "slurm" / "run-local", "noanswer"], env=e)
        assert again.returncode == 0 and "0 cases run (0 no answer), 2 already recorded" in again.stdout, again.stdout
    finally:
        shutil.rmtree(folder)
