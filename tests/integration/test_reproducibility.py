"""analysis.reproducibility (issue 31): two folders of records, compared group by group. Groups whose intervals
overlap count, groups apart are named, disturbed runs are left out, and the share decides the exit status."""
import json
import sys

from conftest import ROOT, run


def folder(path, groups, disturbed=()):
    """A machine folder whose table42 holds one case per entry of groups (its run times), with a state file."""
    exp = path / "table42"
    exp.mkdir(parents=True)
    recs, states = [], []
    for case, times in groups.items():
        for i, t in enumerate(times):
            recs.append({"times_s": {"setup": 0.0, "solve": t}, "result": {"exit_status": 0},
                         "provenance": {"env": {"HPCGI_CASE": case, "HPCGI_REPEAT": str(i)}}})
            states.append({"case": case, "repeat": i, "disturbed": (case, i) in disturbed,
                           "utc": f"2026-12-05T10:00:{i:02d}Z", "probe_before_gbs": 40.0 + i})
        states.append({"case": case, "stop": "interval" if len(times) == 3 else "cap", "n": len(times)})
    (exp / "quick.jsonl").write_text("".join(json.dumps(r) + "\n" for r in recs))
    (exp / "quick.state.jsonl").write_text("".join(json.dumps(s) + "\n" for s in states))
    return path


def compare(a, b):
    return run([sys.executable, "-m", "analysis.reproducibility", str(a), str(b), "quick"], cwd=ROOT, timeout=120)


def test_overlapping_groups_pass_and_the_summaries_are_printed(tmp_path):
    a = folder(tmp_path / "a", {"c1": [1.0, 1.01, 0.99], "c2": [2.0, 2.1, 1.9, 2.05, 1.95]})
    b = folder(tmp_path / "b", {"c1": [1.005, 1.0, 1.02], "c2": [2.02, 2.0, 1.98]})
    p = compare(a, b)
    assert p.returncode == 0, p.stderr
    lines = [json.loads(l) for l in p.stdout.splitlines()]
    assert lines[0] == {"folder": str(a), "met": 1, "capped": 1, "timed_runs": 8, "disturbed": 0,
                        "first_utc": "2026-12-05T10:00:00Z", "last_utc": "2026-12-05T10:00:04Z",
                        "probe_median_gbs": 41.5}
    assert lines[1]["met"] == 2 and lines[1]["timed_runs"] == 6
    assert lines[-1] == {"groups": 2, "overlapping": 2, "share": 1.0}


def test_a_group_apart_is_named_and_the_share_below_90_percent_fails(tmp_path):
    a = folder(tmp_path / "a", {"c1": [1.0, 1.01, 0.99], "c2": [2.0, 2.01, 1.99]})
    b = folder(tmp_path / "b", {"c1": [1.0, 1.01, 0.99], "c2": [3.0, 3.01, 2.99]})
    p = compare(a, b)
    assert p.returncode == 1
    assert "apart: c2: 2 [" in p.stdout
    assert json.loads(p.stdout.splitlines()[-1]) == {"groups": 2, "overlapping": 1, "share": 0.5}


def test_disturbed_runs_are_left_out_of_the_groups(tmp_path):
    # c2's one slow run in b is flagged: without it the intervals overlap; b's c3 keeps 2 runs and is not compared
    a = folder(tmp_path / "a", {"c2": [2.0, 2.01, 1.99], "c3": [1.0, 1.0, 1.0]})
    b = folder(tmp_path / "b", {"c2": [2.0, 2.01, 1.99, 9.0], "c3": [5.0, 5.0, 5.0]},
               disturbed={("c2", 3), ("c3", 0)})
    p = compare(a, b)
    assert json.loads(p.stdout.splitlines()[1])["disturbed"] == 2
    assert json.loads(p.stdout.splitlines()[-1]) == {"groups": 1, "overlapping": 1, "share": 1.0}
    assert p.returncode == 0


def test_bad_arguments_exit_2(tmp_path):
    p = compare(tmp_path / "missing", tmp_path)
    assert p.returncode == 2


def copy_run(src, dst, scale=None):
    """The reference's committed Table 4.2-4.4 records and state files of the quick preset into a machine folder dst
    (scale: {(experiment, method): factor} applied to those runs' solve times)."""
    import shutil
    dst.mkdir(parents=True)
    shutil.copy(src / "machine.json", dst / "machine.json")
    for exp in ("table42", "table43", "table44"):
        (dst / exp).mkdir()
        shutil.copy(src / exp / "quick.state.jsonl", dst / exp / "quick.state.jsonl")
        out = []
        for line in (src / exp / "quick.jsonl").read_text().splitlines():
            r = json.loads(line)
            f = (scale or {}).get((exp, r["params"].get("method")))
            if f:
                r["times_s"]["solve"] *= f
            out.append(json.dumps(r))
        (dst / exp / "quick.jsonl").write_text("\n".join(out) + "\n")


def test_claims_of_two_runs_compared_flips_changes_and_overlap_last_as_one_json_line(tmp_path):
    """--claims (issue 49): the same records twice give no flip, no change and every interval overlapping; BiCG-STAB
    made 4 times slower in one of them flips its time parts where ours found it faster, and says which."""
    ref = ROOT / "results" / (ROOT / "results" / "REFERENCE").read_text().strip()
    res = tmp_path / "results"
    copy_run(ref, res / "run-a")
    copy_run(ref, res / "run-b")
    copy_run(ref, res / "run-c", scale={("table42", "bicgstab"): 4.0})
    env = {"RESULTS": str(res), "ANALYSIS_ALL_RECORDS": "1"}
    p = run([sys.executable, "-m", "analysis.reproducibility", "--claims", "run-a", "run-b", "quick"], env=env,
            cwd=ROOT, timeout=300)
    assert p.returncode == 0, p.stderr
    last = json.loads(p.stdout.strip().splitlines()[-1])
    assert set(last) == {"claims", "flips", "changed", "overlap_share"} and last["claims"] >= 6
    assert last["flips"] == 0 and last["changed"] == 0 and last["overlap_share"] == 1.0, last
    p = run([sys.executable, "-m", "analysis.reproducibility", "--claims", "run-a", "run-c", "quick"], env=env,
            cwd=ROOT, timeout=300)
    last = json.loads(p.stdout.strip().splitlines()[-1])
    assert last["overlap_share"] < 1.0 and last["flips"] + last["changed"] >= 1, p.stdout
    assert any(l.startswith("differs: BiCG-STAB") and "time, BiCG-STAB over Jacobi" in l
               for l in p.stdout.splitlines()), p.stdout
    bad = run([sys.executable, "-m", "analysis.reproducibility", "--claims", "run-a", "nowhere"], env=env, cwd=ROOT)
    assert bad.returncode == 2 and "no machine folder nowhere" in bad.stderr
