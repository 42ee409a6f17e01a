"""The analysis side of the measurement protocol (issue 31): records from dirty trees and unknown commits are left
out of the tables and counted; the runner's state files are joined, a disturbed run is left out of the medians and
counted, a group stopped at its cap or wider than +-5% is marked capped; and the reference machine's committed
records obey the protocol."""
import json
import shutil
import subprocess
import sys

import numpy as np
import pytest

from conftest import ROOT

sys.path.insert(0, str(ROOT))
from analysis import protocol, records  # noqa: E402

REF = (ROOT / "results" / "REFERENCE").read_text().strip()
HEAD = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
TIMED = ("table41", "table42", "table43", "table44", "table45")


def fixture(tmp_path, monkeypatch, times):
    """Records of one case (repeats 0..n-1, solve times `times`) in tmp_path/m/table42/ci.jsonl, all of HEAD."""
    base = json.loads((ROOT / "results" / REF / "table42" / "quick.jsonl").read_text().splitlines()[0])
    lines = []
    for i, t in enumerate(times):
        r = json.loads(json.dumps(base))
        r["provenance"].update(git_commit=HEAD, git_dirty=False, utc=f"2026-01-01T00:00:{i:02d}Z")
        r["provenance"]["env"].update(HPCGI_CASE="ci/table42/0/x", HPCGI_REPEAT=str(i))
        r["times_s"].update(setup=0.0, solve=t)
        lines.append(r)
    f = tmp_path / "m" / "table42" / "ci.jsonl"
    f.parent.mkdir(parents=True)
    monkeypatch.setattr(records, "RESULTS", tmp_path)
    monkeypatch.setitem(records._state, "machine", "m")  # restored after the test, as RESULTS is
    return f, lines


def write(f, lines):
    f.write_text("".join(json.dumps(r) + "\n" for r in lines))


def test_dirty_and_unknown_commits_are_left_out_and_counted(tmp_path, monkeypatch):
    f, lines = fixture(tmp_path, monkeypatch, [1.0, 1.0, 1.0, 1.0, 9.0, 9.0])
    lines[4]["provenance"]["git_dirty"] = True
    lines[5]["provenance"]["git_commit"] = "0123456789abcdef0123456789abcdef01234567"  # not in this repository
    lines[5]["provenance"]["env"]["HPCGI_CASE"] = "ci/table42/1/y"
    write(f, lines)
    df = records.load("table42", "ci")
    assert len(df) == 4 and df["times_s.solve"].max() == 1.0
    text = protocol.note([str(f)])
    assert "1 from a working tree with uncommitted changes" in text and "1 from a commit not in this repository" in text
    assert "4 without machine state" in text
    protocol.include_all(True)
    try:
        assert len(records.load("table42", "ci")) == 6
    finally:
        protocol.include_all(False)


def test_state_file_flags_disturbed_runs_and_capped_groups(tmp_path, monkeypatch):
    f, lines = fixture(tmp_path, monkeypatch, [1.0, 1.01, 0.99, 1.0, 1.02, 7.0])
    write(f, lines)
    state = [{"case": "ci/table42/0/x", "repeat": i, "utc": "x", "load_before": 0.1, "load_after": 0.1,
              "probe_before_gbs": 10.0, "probe_after_gbs": 10.0 if i != 5 else 4.0, "disturbed": i == 5,
              "reason": "probe fell 60%" if i == 5 else None} for i in range(6)]
    stop = {"case": "ci/table42/0/x", "stop": "interval", "n": 6}
    f.with_name("ci.state.jsonl").write_text("".join(json.dumps(s) + "\n" for s in [*state, stop]))
    df = records.load("table42", "ci")
    assert len(df) == 5 and df["times_s.solve"].max() < 2  # the disturbed run is out of the median
    assert "1 run while the machine was disturbed" in protocol.note([str(f)])
    s = records.summarise(df.assign(t=df["times_s.solve"]), ["params.method"], "t")
    assert not s["capped"].iloc[0] and s["repeats"].iloc[0] == 5
    f.with_name("ci.state.jsonl").write_text("".join(json.dumps(s) + "\n" for s in [*state, {**stop, "stop": "cap"}]))
    df = records.load("table42", "ci")
    assert records.summarise(df.assign(t=df["times_s.solve"]), ["params.method"], "t")["capped"].iloc[0]
    # a tight stop but a wide interval is capped too
    assert protocol.capped(1.0, 0.8, 1.2) and not protocol.capped(1.0, 0.97, 1.03)


def committed(preset=None):
    out = subprocess.run(["git", "ls-files", f"results/{REF}"], cwd=ROOT, capture_output=True, text=True).stdout
    return [ROOT / p for p in out.split() if p.endswith(".jsonl") and not p.endswith(".state.jsonl")
            and (preset is None or p.endswith(f"/{preset}.jsonl"))]


def groups(preset):
    """(experiment, case, n, median, lo, hi, capped, disturbed used) of every timed group of the reference."""
    out = []
    with records.on(REF):
        for exp in TIMED:
            df = records.load(exp, preset)
            if df.empty or "provenance.env.HPCGI_CASE" not in df:
                continue
            for case, g in df.groupby("provenance.env.HPCGI_CASE"):
                t = (g["times_s.setup"] + g["times_s.solve"]).to_numpy()
                lo, hi = records.median_ci(t) if len(t) >= 3 else (np.nan, np.nan)
                med = float(np.median(t))
                cap = protocol.capped(med, lo, hi, g["protocol.stop"].dropna())
                out.append((exp, case, len(t), med, lo, hi, cap, bool(g["protocol.disturbed"].any()),
                            g["protocol.stop"].isna().all()))
    return out


def test_reference_records_obey_the_protocol():
    files = committed()
    assert files
    commits = set()
    for f in files:
        for n, line in enumerate(f.read_text().splitlines(), 1):
            p = json.loads(line)["provenance"]
            assert p.get("git_dirty") is False, f"{f}:{n}: from a dirty tree"
            commits.add(p["git_commit"])
    assert protocol.known(commits) == commits, f"unknown commits: {sorted(commits - protocol.known(commits))}"
    for preset in ("quick", "paper"):
        for exp, case, n, med, lo, hi, cap, disturbed, no_state in groups(preset):
            where = f"{exp} {case}: n={n}, median {med:.4g} [{lo:.4g}, {hi:.4g}]"
            assert not no_state, f"{where}: no machine state"
            assert n >= 5 or (n >= 3 and not protocol.capped(med, lo, hi)), f"{where}: too few runs"
            assert cap or (hi - med <= 0.05 * med and med - lo <= 0.05 * med), where
            assert not disturbed, f"{where}: a disturbed run inside the median"


def test_python_records_count_dirty_as_the_binaries_do(tmp_path):
    """common.record's git_dirty follows the Makefile's GIT_CHANGES: a run that appends to a committed record file
    (results/) leaves the tree clean, a changed or new source file makes it dirty. (The Python peers of a second
    make bench on a machine with committed records were all marked dirty before.)"""
    clone = tmp_path / "clone"
    subprocess.run(["git", "clone", "-q", "--no-checkout", str(ROOT), str(clone)], check=True)
    subprocess.run(["git", "checkout", "-q", "HEAD", "--", "analysis", "common"], cwd=clone, check=True)
    subprocess.run(["git", "reset", "-q"], cwd=clone, check=True)
    for d in ("analysis", "common"):  # this tree's code, committed or not
        shutil.copytree(ROOT / d, clone / d, dirs_exist_ok=True, ignore=shutil.ignore_patterns("__pycache__"))
    subprocess.run(["git", "add", "analysis", "common"], cwd=clone, check=True)
    # only analysis/ and common/ checked out: the rest of the tree "deleted" would count as changes, so commit that
    subprocess.run(["git", "-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qam", "only what the test needs"],
                   cwd=clone, check=True)

    def dirty():
        p = subprocess.run([sys.executable, "-c", "from common import record; "
                            "print(record.provenance()['git_dirty'])"], cwd=clone, capture_output=True, text=True)
        assert p.returncode == 0, p.stderr
        return p.stdout.strip()

    assert dirty() == "False"
    (clone / "results" / "m").mkdir(parents=True)
    (clone / "results" / "m" / "r.jsonl").write_text("{}\n")
    (clone / "report").mkdir()
    (clone / "report" / "R.md").write_text("x\n")
    assert dirty() == "False"
    (clone / "analysis" / "new.py").write_text("")
    assert dirty() == "True"
    (clone / "analysis" / "new.py").unlink()
    with open(clone / "analysis" / "escape.py", "a") as f:
        f.write("# changed\n")
    assert dirty() == "True"
