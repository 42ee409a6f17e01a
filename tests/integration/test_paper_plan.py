"""The paper preset's plan on a small machine (issue 50): cases with more ranks than cores are skipped and said, the
cores a case may use fill {CORES}, a long case's repeat=K caps its runs, and the estimate scales this machine's own
records of a smaller preset by each case's work. The tiny ci preset, on one core (taskset), stands in for a cluster
preset on a small machine."""
import json
import shutil

import pytest

from conftest import ROOT, run

MACHINE = "paper-plan-test"
pytestmark = pytest.mark.skipif(shutil.which("taskset") is None, reason="taskset (util-linux) is not installed")


def env(tmp_path, **kw):
    return {"RESULTS": str(tmp_path / "results"), "FF_DIR": str(tmp_path / "ff"), "PRESET": "ci", "MACHINE": MACHINE,
            **kw}


def case_lines(preset, exp):
    return [l for l in (ROOT / "slurm" / "cases" / preset / f"{exp}.txt").read_text().splitlines()
            if l.strip() and not l.startswith("#")]


def test_on_one_core_the_two_rank_cases_are_skipped_and_said_and_the_rest_run_with_progress(tmp_path):
    p = run(["taskset", "-c", "0", ROOT / "slurm" / "run-local", "table41"], env=env(tmp_path, REPEAT="1"),
            timeout=900)
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    two = [k for k, l in enumerate(case_lines("ci", "table41")) if l.startswith("ranks=2 ")]
    assert two
    skipped = [json.loads(l) for l in (tmp_path / "results" / MACHINE / "table41" / "ci.skipped").read_text().splitlines()]
    cores = {int(s["case"].split("/")[2]) for s in skipped if s["reason"] == "needs >= 2 cores"}
    assert cores == set(two), skipped  # (the GPU cases beside them: "no GPU on this machine")
    assert "skipped, more MPI ranks than this machine's 1 cores" in p.stdout, p.stdout[-2000:]
    recs = [json.loads(l) for l in (tmp_path / "results" / MACHINE / "table41" / "ci.jsonl").read_text().splitlines()]
    assert recs and all(r["params"].get("ranks", 1) == 1 for r in recs)
    assert all("HPCGI_OVERSUBSCRIBED" not in r["provenance"]["env"] for r in recs)
    progress = [l for l in p.stdout.splitlines() if l.startswith("run-local: progress: ")]
    assert len(progress) == len(recs), progress  # one line per run (REPEAT=1: one a case)
    assert progress[-1].split(", ")[1] == f"{len(recs)}/{len(recs)} runs", progress[-1]  # the plan's count of runs
    assert progress[-1].endswith("no estimate of the time left (this machine has no quick records to scale yet)")


def test_oversubscribe_runs_them_and_says_so_in_the_record(tmp_path):
    k = next(k for k, l in enumerate(case_lines("ci", "table41")) if l.startswith("ranks=2 "))
    p = run(["taskset", "-c", "0", ROOT / "slurm" / "run-case", "table41", str(k)],
            env=env(tmp_path, REPEAT="1", OVERSUBSCRIBE="1"), timeout=300)
    assert p.returncode == 0, p.stderr
    rec = json.loads((tmp_path / "results" / MACHINE / "table41" / "ci.jsonl").read_text().splitlines()[0])
    assert rec["params"]["ranks"] == 2 and rec["provenance"]["env"]["HPCGI_OVERSUBSCRIBED"] == "1"


def test_cores_fill_the_token_and_a_long_case_runs_its_own_repeat_count(tmp_path):
    lines = case_lines("paper", "table41")
    omp = next(k for k, l in enumerate(lines) if "--backend openmp --threads {CORES} --n 1024 " in l)
    long = next(k for k, l in enumerate(lines) if l.startswith("repeat=2 ranks=1 ") and "--n 8192 " in l)
    e = env(tmp_path, PRESET="paper", REPEAT="6", DRY_RUN="1")
    p = run(["taskset", "-c", "0", ROOT / "slurm" / "run-case", "table41", str(omp)], env=e)
    assert p.returncode == 0 and "--threads 1 --n 1024" in p.stdout and p.stdout.count("would run") == 6, p.stdout
    p = run([ROOT / "slurm" / "run-case", "table41", str(long)], env=e)
    assert p.returncode == 0 and p.stdout.count("would run") == 2, p.stdout  # repeat=2 caps REPEAT=6


def write_state(tmp_path, preset, exp, walls):
    """A state file of this machine's runs of `preset` with the given wall seconds per case index."""
    from gpukit import cases
    lines = []
    for c in cases.read(ROOT / "slurm" / "cases" / preset / f"{exp}.txt", preset):
        for r, w in enumerate(walls.get(c.index, [])):
            lines.append(json.dumps({"case": c.case_id, "repeat": r, "wall_s": w, "exit_status": 0,
                                     "disturbed": False}))
    d = tmp_path / "results" / MACHINE / exp
    d.mkdir(parents=True, exist_ok=True)
    (d / f"{preset}.state.jsonl").write_text("\n".join(lines) + "\n")


def per_case(path):
    return {c: (int(n), None if s == "-" else float(s))
            for c, n, s in (l.split() for l in path.read_text().splitlines())}


def test_the_estimate_scales_each_case_by_its_work_from_this_machines_smaller_preset(tmp_path):
    ci = case_lines("ci", "table41")
    plain1 = next(k for k, l in enumerate(ci) if l == "ranks=1 bin/poisson --backend mpi --n 32 --max-iter 100000")
    mg1 = next(k for k, l in enumerate(ci) if l == "ranks=1 bin/poisson --backend mpi --n 32 --precond mg")
    write_state(tmp_path, "ci", "table41", {plain1: [2.0, 4.0, 3.0], mg1: [1.0, 1.0, 1.0]})
    out = tmp_path / "plan.txt"
    p = run(["taskset", "-c", "0", "python3", ROOT / "common" / "estimate.py", "quick", "--from", "ci", "--per-case",
             out, "table41"], env=env(tmp_path), cwd=ROOT)
    assert p.returncode == 0, p.stderr
    plan = per_case(out)
    quick = case_lines("quick", "table41")
    # quick's timed solves take --min-time 0.1 (ci's do not): about 0.1 s more a run
    k = quick.index("ranks=1 bin/poisson --backend mpi --n 256 --max-iter 100000 --min-time 0.1")
    assert plan[f"table41/{k}"] == (6, pytest.approx(3.0 * (256 / 32) ** 3 + 0.1 + 1.0))  # plain CG: (N/N0)^3
    k = quick.index("ranks=1 bin/poisson --backend mpi --n 1024 --precond mg --min-time 0.1")
    assert plan[f"table41/{k}"] == (6, pytest.approx(1.0 * (1024 / 32) ** 2 + 0.1 + 1.0))  # MG-PCG: (N/N0)^2
    k = quick.index("ranks=2 bin/poisson --backend mpi --n 256 --max-iter 100000 --min-time 0.1")
    assert plan[f"table41/{k}"] == (0, None)  # 2 ranks on one core: skipped, no runs
    k = quick.index("bin/poisson --backend cublas1 --n 256 --max-iter 100000 --min-time 0.1")
    assert plan[f"table41/{k}"][0] == 0  # no GPU here
    k = quick.index("bin/poisson --backend openmp --threads 2 --n 256 --max-iter 100000 --min-time 0.1")
    assert plan[f"table41/{k}"] == (6, None)  # no twin among the records: listed, never guessed
    assert "no estimate for" in p.stdout and "estimate: total " in p.stdout.splitlines()[-1], p.stdout
    bad = run(["python3", ROOT / "common" / "estimate.py", "paper", "no-such-experiment"], env=env(tmp_path), cwd=ROOT)
    assert bad.returncode == 2 and "no experiment 'no-such-experiment'" in bad.stderr
