"""The measurement protocol's side of the analysis (issue 31, docs: Hoefler and Belli, SC15): which records a table
may use, and how tight each timed group is.

- A record from a dirty tree (provenance.git_dirty) or from a commit this repository does not hold is left out by
  default (`include_all(True)`, `python -m analysis ... --all-records`, keeps them).
- The runner writes beside each records file <preset>.jsonl a state file <preset>.state.jsonl: per timed run
  {"case", "repeat", "utc", "load_before", "load_after", "probe_before_gbs", "probe_after_gbs", "disturbed",
  "reason"}, per finished group {"case", "stop": "interval"|"cap", "n"}. A disturbed run stays in the records and
  is left out of medians. Records of a file without a state file are used as before, counted as "no machine state".
- A group is capped when its runner stopped at the cap, or when the 95% interval of its median is wider than +-5%
  of the median.

Every record left out, and every one without machine state, is counted per records file (COUNTS), and
`note(files)` says so in one sentence under each table."""
import os
import subprocess
import sys
from collections import Counter, defaultdict
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parent.parent
# The timing protocol's one definition of a median's interval and its target (common/timing_protocol.py): the
# runner stops repeating a case by it, and the tables show it.
from common import harness_io  # noqa: E402  (the one way to open a harness file)
from common import timing_protocol  # noqa: E402

TARGET = timing_protocol.TARGET  # the 95% interval of a group's median within +-5% of it
WHY = {"dirty": "from a working tree with uncommitted changes", "unknown_commit": "from a commit not in this repository",
       "disturbed": "run while the machine was disturbed (its state file says why)",
       "no_state": "without machine state (made before the protocol: no state file)"}
LEFT_OUT = ("dirty", "unknown_commit", "disturbed")

COUNTS = defaultdict(Counter)  # records file -> Counter of WHY's keys
# ANALYSIS_ALL_RECORDS=1 is --all-records for a whole process tree (the tests that make records from the working
# tree, clean or not, and check that tables get written from them).
_settings = {"all": os.environ.get("ANALYSIS_ALL_RECORDS") == "1"}
_commits = {}


def include_all(on=True):
    """Keep records from dirty trees and unknown commits, and runs flagged as disturbed (for a developer's look and
    for the tests' own records, never for results/)."""
    _settings["all"] = bool(on) or os.environ.get("ANALYSIS_ALL_RECORDS") == "1"


def known(commits):
    """Which of these commits this repository holds (git cat-file -e <commit>^{commit}), asked once per commit."""
    ask = sorted({str(c) for c in commits if str(c) not in _commits})
    if ask:
        try:
            p = subprocess.run(["git", "cat-file", "--batch-check"], cwd=ROOT, capture_output=True, text=True,
                               input="".join(f"{c}^{{commit}}\n" for c in ask), timeout=60)
            lines = p.stdout.splitlines() if p.returncode == 0 else ["missing"] * len(ask)
        except (OSError, subprocess.SubprocessError):
            lines = ["missing"] * len(ask)
        for c, line in zip(ask, lines):
            _commits[c] = not line.endswith("missing") and c not in ("", "unknown")
    return {c for c in map(str, commits) if _commits.get(c)}


BAD_STATE = []  # (state file, line, why) of the state lines left out: named on stderr, counted


def state(records_file):
    """(runs, stops) of a records file's state file: runs (case, repeat) -> its state, stops case -> "interval" or
    "cap"; None when there is no state file. A line that is no JSON object naming its case (and, for a run, its
    repeat as a whole number) is named with its file and line on stderr, counted in BAD_STATE, and left out; a state
    file that is no regular file (a FIFO, a device) is named and read as none."""
    f = Path(str(records_file)[: -len(".jsonl")] + ".state.jsonl")
    try:
        good, bad = harness_io.read_objects(f)
    except harness_io.HarnessFileError as e:
        BAD_STATE.append((str(f), 0, str(e)))
        print(f"analysis: {e}: its runs are counted as without machine state", file=sys.stderr)
        return None
    if not good and not bad and not f.exists():
        return None
    runs, stops = {}, {}
    for n, s in good:
        if not isinstance(s.get("case"), str):
            bad.append((n, 'no "case"'))
        elif "stop" in s:
            stops[s["case"]] = s["stop"]
        elif isinstance(s.get("repeat"), int) and not isinstance(s.get("repeat"), bool):
            runs[(s["case"], s["repeat"])] = s
        elif "repeat" in s:
            bad.append((n, f"its repeat {str(s['repeat'])[:20]!r} is no whole number"))
    for n, why in bad:
        BAD_STATE.append((str(f), n, why))
        print(f"analysis: {f}:{n}: no state line ({why}), left out", file=sys.stderr)
    return runs, stops


def _unclean(df):
    """(dirty, unknown commit) masks of df's records."""
    dirty = df["provenance.git_dirty"].fillna(False).astype(bool) if "provenance.git_dirty" in df \
        else pd.Series(False, index=df.index)
    commit = df["provenance.git_commit"].astype(str) if "provenance.git_commit" in df else pd.Series("", index=df.index)
    return dirty, ~commit.isin(known(set(commit))) & ~dirty


def provenance_filter(df, newest):
    """newest(df) of df's clean records (unless include_all). Counted per file: the records from dirty trees and
    unknown commits not superseded by the clean records kept (of a case with none kept, or made since the first of
    them)."""
    if df.empty or _settings["all"]:
        return newest(df)
    dirty, unknown = _unclean(df)
    kept = newest(df[~(dirty | unknown)])
    case = "provenance.env.HPCGI_CASE"
    if case in df and "provenance.utc" in df:
        first = kept.groupby(case)["provenance.utc"].min() if len(kept) else pd.Series(dtype=object)
        since = df[case].map(first)
        live = since.isna() | (df["provenance.utc"] >= since.fillna(""))
    else:
        live = pd.Series(True, index=df.index)
    for why, mask in (("dirty", dirty), ("unknown_commit", unknown)):
        for f, n in df[mask & live].groupby("file").size().items():
            COUNTS[f][why] = int(n)
    return kept


def machine_state(df):
    """df with the machine's state joined (protocol.disturbed, protocol.reason, protocol.stop), the disturbed runs
    left out and counted, and the records of files without a state file counted as "no machine state"."""
    if df.empty:
        return df
    df = df.copy()
    df["protocol.disturbed"], df["protocol.reason"], df["protocol.stop"] = False, None, None
    df["protocol.block"] = None  # the block whose rounds the run was in (slurm/run-local: the pairs of a claim)
    case = df["provenance.env.HPCGI_CASE"] if "provenance.env.HPCGI_CASE" in df else pd.Series(None, index=df.index)
    rep = df["provenance.env.HPCGI_REPEAT"] if "provenance.env.HPCGI_REPEAT" in df else pd.Series(None, index=df.index)
    for f, idx in df.groupby("file").groups.items():
        st = state(f)
        if st is None:
            COUNTS[f]["no_state"] = len(idx)
            continue
        runs, stops = st
        for i in idx:
            s = runs.get((case[i], int(rep[i]))) if str(rep[i]).isdigit() else None
            if s and s.get("disturbed"):
                df.at[i, "protocol.disturbed"], df.at[i, "protocol.reason"] = True, s.get("reason")
            if s and isinstance(s.get("block"), str):
                df.at[i, "protocol.block"] = s["block"]
            df.at[i, "protocol.stop"] = stops.get(case[i])
        COUNTS[f]["disturbed"] = int(df.loc[idx, "protocol.disturbed"].sum())
    # A developer's look (--all-records) keeps the disturbed runs too, still counted under each table.
    return df if _settings["all"] else df[~df["protocol.disturbed"]]


def capped(median, lo, hi, stops=()):
    """Whether a group missed the interval target: its runner stopped at the cap, or its 95% interval is not within
    +-5% of its median (no interval: capped)."""
    if "cap" in set(stops):
        return True
    if not (median == median and lo == lo and hi == hi) or median == 0:
        return True
    return (hi - median) > TARGET * abs(median) or (median - lo) > TARGET * abs(median)


def note(files):
    """One sentence: how many records of these files each rule left out, and how many lack machine state."""
    total = Counter()
    for f in set(map(str, files)):
        total.update(COUNTS.get(f, {}))
    parts = [f"{total[k]} {WHY[k]}" for k in LEFT_OUT if total[k]]
    text = f"Left out of the medians: {'; '.join(parts)}." if parts else "No record left out."
    if _settings["all"]:
        text = ("Records from dirty trees and unknown commits kept (--all-records: a developer's look, not results). "
                + text)
    if total["no_state"]:
        text += f" Of those used, {total['no_state']} {WHY['no_state']}."
    return text


def machine_time(folder, preset):
    """What a preset cost this machine, from every file of its folder (used or not): {"seconds": the runs' wall time
    (the state files' for the timed runs, the records' own total for the others), "runs", "disturbed": the runs
    flagged disturbed, "first"/"last": the UTC of the first and last run, "commits": the commits that made them}."""
    out = {"seconds": 0.0, "runs": 0, "disturbed": 0, "first": None, "last": None, "commits": set()}
    for rec_file in sorted(Path(folder).glob(f"*/{preset}.jsonl")):
        timed = set()
        try:  # the state file's bad lines are named by state(), once, where the tables read it
            runs, _ = harness_io.read_objects(rec_file.with_name(f"{preset}.state.jsonl"))
            good, _ = harness_io.read_objects(rec_file)
        except harness_io.HarnessFileError:
            continue
        for _, s in runs:
            if "stop" in s or not isinstance(s.get("case"), str):
                continue
            timed.add(s["case"])
            out["runs"] += 1
            out["disturbed"] += s.get("disturbed") is True
            out["seconds"] += float(s["wall_s"]) if isinstance(s.get("wall_s"), (int, float)) else 0.0
        for _, r in good:
            prov, utc = r.get("provenance") or {}, None
            utc = prov.get("utc") if isinstance(prov.get("utc"), str) else None
            if utc:
                out["first"] = min(out["first"] or utc, utc)
                out["last"] = max(out["last"] or utc, utc)
            if isinstance(prov.get("git_commit"), str):
                out["commits"].add(prov["git_commit"][:12])
            if str((prov.get("env") or {}).get("HPCGI_CASE")) not in timed:
                out["runs"] += 1
                total = (r.get("times_s") or {}).get("total")
                out["seconds"] += float(total) if isinstance(total, (int, float)) else 0.0
    return out
