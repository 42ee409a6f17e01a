"""Loading run records (JSON Lines) into flat pandas frames, and summarising repeats.

Records belong to the machine that made them: results/<machine>/<experiment>/<preset>.jsonl, one folder per
machine label (common/machine_label.py). Everything here reads and writes for one machine at a time, the current
one (`machine()`: set by `use(label)`, else $MACHINE, else this machine's label); `on(label)` switches to another
for a while (the reference machine's numbers beside this machine's), without writing any file for it."""
import contextlib
import os
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from analysis import protocol
from analysis.escape import md
from common.record import loads, validate

ROOT = Path(__file__).resolve().parent.parent
# Records, tables and plots live in $RESULTS (default results/), the report's published numbers in results/paper.
RESULTS = Path(os.environ.get("RESULTS", ROOT / "results")).resolve()
PAPER = ROOT / "results" / "paper"

from common import harness_io  # noqa: E402  (the one way to open a harness file)
from common import machine_label  # noqa: E402

_state = {"machine": None, "write": True}


def use(label):
    """Makes `label` the current machine (checked as a folder name)."""
    _state["machine"] = machine_label.check(label)


def machine():
    """The current machine's label: as set by use(), else $MACHINE, else this machine's own."""
    if _state["machine"] is None:
        _state["machine"] = machine_label.this_machine()
    return _state["machine"]


def reference():
    """The reference machine every report compares against (results/REFERENCE), or None where there is none."""
    f = RESULTS / "REFERENCE"
    try:
        label = (harness_io.read_bytes(f) or b"").decode(errors="replace").strip()
    except harness_io.HarnessFileError:
        label = ""
    return label if label and (RESULTS / label).is_dir() else None


def machines():
    """Every machine with a folder of records in results/, sorted."""
    return sorted(d.name for d in RESULTS.iterdir() if d.is_dir() and d.name not in machine_label.RESERVED
                  and not d.name.startswith(".")) if RESULTS.is_dir() else []


@contextlib.contextmanager
def on(label, write=False):
    """Reads another machine's records for a while; its tables and plots are not written unless write=True."""
    saved = dict(_state)
    _state.update(machine=label, write=write)
    try:
        yield
    finally:
        _state.update(saved)


def writing():
    """Whether tables and plots are written now (not while another machine is read beside this one)."""
    return _state["write"]


def machine_dir(label=None):
    return RESULTS / (label or machine())


def tables_dir():
    return machine_dir() / "tables"


def plots_dir():
    return machine_dir() / "plots"


def report_dir():
    """The reproduced report of the current machine: report/<machine>/ for the project's own results, beside the
    records for any other results folder."""
    top = ROOT / "report" if RESULTS == (ROOT / "results").resolve() else RESULTS / "report"
    return top / machine()

# The report's scene numbers: 1 and 2 are our scenes, 3 and 4 RRV's rooms.
SCENE_IDS = {"scene1.xml": 1, "scene2.xml": 2, "room3.xml": 3, "room2.xml": 4}


# What a table or section says where it has no records to use.
NONE_USED = 'none recorded, or all left out: see "Experiments of this preset"'

# (file, line, what) of every record that did not validate since the program started: left out, and reported.
INVALID = []


def read_jsonl(path, records=True):
    """The records of one file (a harness file: a FIFO or a device is refused, common/harness_io.py). A line that is
    no JSON object, or with records=True no valid record against the schema, is reported on stderr with its file and
    line, kept in INVALID, and left out (never silently used, and never the end of the analysis)."""
    rows = []
    try:
        data = harness_io.read_bytes(path, harness_io.LARGE) or b""
    except harness_io.HarnessFileError as e:
        INVALID.append((str(path), 0, str(e)))
        print(f"analysis: {e}: left out", file=sys.stderr)
        return rows
    for n, raw in enumerate(data.split(b"\n"), 1):
        if not raw.strip():
            continue
        try:
            rec = loads(raw.decode("utf-8"))
            wrong = None if isinstance(rec, dict) else f"a JSON {type(rec).__name__}, no object"
        except (ValueError, UnicodeDecodeError, RecursionError) as e:
            rec, wrong = None, f"not JSON ({str(e)[:80]})"
        wrong = wrong or (validate(rec) if records else None)
        if wrong:
            INVALID.append((str(path), n, wrong))
            print(f"analysis: {path}:{n}: not a valid {'hpcgi-record/1 record' if records else 'line'}, left out: "
                  f"{wrong}", file=sys.stderr)
            continue
        rows.append(rec)
    return rows


def newest(df):
    """Per line of a case list (the runner's HPCGI_CASE, PRESET/EXPERIMENT/LINE/HASH, less the hash of the line's
    words), only the records of the newest commit that ran it: a case re-run after a change (`REPEAT=10` adds repeats
    5..9), or a line changed in place (issue 49 added --min-time to the timed solves), is told by the new code's
    numbers, never pooled with the old, and the older records stay in the file as history. Records made outside the
    runner (no case) are all kept."""
    case, commit = "provenance.env.HPCGI_CASE", "provenance.git_commit"
    if df.empty or case not in df or commit not in df:
        return df
    line = df[case].map(lambda c: c.rsplit("/", 1)[0] if isinstance(c, str) else c)
    last = df.assign(line=line).sort_values("provenance.utc").groupby("line")[commit].last()
    return df[df[case].isna() | (df[commit] == line.map(last))]


def load(experiment, preset=None, history=False):
    """The current machine's records of an experiment (one preset, or every preset) as one flat frame, columns like
    'params.n': of each case those of its newest commit (see newest), or with history=True all. Records from dirty
    trees or unknown commits, and runs flagged as disturbed, are left out and counted (analysis/protocol.py)."""
    rows = []
    for f in sorted((machine_dir() / experiment).glob(f"{preset or '*'}.jsonl")):
        for rec in read_jsonl(f):
            rec["file"] = str(f)
            rows.append(rec)
    df = pd.json_normalize(rows) if rows else pd.DataFrame()
    if not df.empty:
        df["exit_status"] = df.apply(exit_status, axis=1).astype(int)
    if "params.scene" in df.columns:
        df["scene_id"] = df["params.scene"].map(lambda s: SCENE_IDS.get(Path(s).name) if isinstance(s, str) else None)
    if history:
        return df
    return protocol.machine_state(protocol.provenance_filter(df, newest))


# The exit statuses of common/errors.hpp that a record can carry: every run but 0 is no answer.
NO_ANSWER = {3: "numerical failure", 4: "not converged within --max-iter", 5: "disagreed with its float64 check"}
FAILED = ("breakdown", "nonfinite", "divergent", "stagnant", "unphysical")


def exit_status(row):
    """A record's exit status: result.exit_status where the record has it, else (records made before it was
    recorded) what its status and float64 check say: 3 failed, 4 max_iter, 5 disagreed, 0 an answer."""
    s = row.get("result.exit_status")
    if s is not None and not (isinstance(s, float) and np.isnan(s)):
        return int(s)
    status = row.get("result.status")
    if status in FAILED:
        return 3
    if status == "max_iter":
        return 4
    return 5 if row.get("verify.agreed") is False else 0


def no_answer_note(df):
    """One sentence naming the runs of `df` that are no answer (exit status 3, 4 or 5), which the tables leave out
    of their medians; empty when every run is an answer."""
    if df.empty or "exit_status" not in df:
        return ""
    bad = df[df["exit_status"] != 0]
    if bad.empty:
        return ""
    parts = []
    for code, g in bad.groupby("exit_status"):
        what = ", ".join(sorted({" ".join(str(a) for a in r["argv"][1:] if a not in ("--quiet",))
                                 if isinstance(r.get("argv"), list) else str(r.get("provenance.env.HPCGI_CASE"))
                                 for _, r in g.head(3).iterrows()}))
        parts.append(f"{len(g)} with exit status {int(code)} ({NO_ANSWER.get(int(code), 'unknown')}; e.g. {md(what)})")
    return f"No answer, left out of the numbers above: {'; '.join(parts)}."


def skipped(experiment, preset):
    """Cases the runner skipped on the current machine (a GPU case on a machine without one, a case of RRV's scenes
    where there were none) and that have no record since, as a frame with case, host, reason."""
    f = machine_dir() / experiment / f"{preset}.skipped"
    s = pd.DataFrame(read_jsonl(f, records=False)) if f.exists() else pd.DataFrame(columns=["case", "host", "utc", "reason"])
    done = load(experiment, preset, history=True)
    if len(s) and not done.empty and "provenance.env.HPCGI_CASE" in done:
        s = s[~s["case"].isin(set(done["provenance.env.HPCGI_CASE"].dropna()))]
    return s.drop_duplicates("case", keep="last") if len(s) else s


def paper_table(name):
    """The report's published numbers, transcribed once into results/paper/NAME.csv."""
    return pd.read_csv(PAPER / f"{name}.csv", comment="#")


def median_ci(values, level=0.95):
    """The distribution-free interval of the median (order statistics): the timing protocol's one definition
    (common/timing_protocol.py), by which the runner stops repeating a case."""
    return protocol.timing_protocol.median_ci(list(np.asarray(values, dtype=float)), level=level)


def coverage(n, level=0.95):
    """The true coverage of median_ci's interval for n values (below `level` for fewer than 6)."""
    return protocol.timing_protocol.coverage(int(n), level)


def summarise(df, keys, value, ci_from=3):
    """Median of `value` over repeats per `keys`, with min, max, repeat count, from `ci_from` repeats on the
    distribution-free interval of the median with its true coverage (95%, or what the count allows), and `capped`
    (analysis/protocol.py: the runner stopped at its cap, or the interval is not within +-5% of the median)."""
    rows = []
    for k, g in df.groupby(keys, dropna=False):
        v = g[value].dropna()
        row = dict(zip(keys, k if isinstance(k, tuple) else (k,)))
        row.update(median=v.median(), min=v.min(), max=v.max(), repeats=len(v))
        row["ci_low"], row["ci_high"] = median_ci(v) if len(v) >= ci_from else (np.nan, np.nan)
        row["coverage"] = coverage(len(v)) if len(v) >= ci_from else np.nan
        stops = g["protocol.stop"].dropna() if "protocol.stop" in g else ()
        row["capped"] = protocol.capped(row["median"], row["ci_low"], row["ci_high"], stops)
        rows.append(row)
    return pd.DataFrame(rows)


def cell(row, fmt=".4g"):
    """A timing cell: the median, its interval (with its true coverage where that is below 95%: 75% for 3 runs) and n
    ("capped" where the group missed the +-5% target), from a summarise row (anything with median, ci_low, ci_high,
    repeats, capped); "—" where there is none."""
    if row is None or not np.isfinite(row["median"]):
        return "—"
    lo, hi = row["ci_low"], row["ci_high"]
    cov = row.get("coverage", np.nan)
    ci = (f" [{lo:{fmt}}, {hi:{fmt}}]" + (f" {cov:.0%}" if np.isfinite(cov) and cov < 0.95 else "")
          if np.isfinite(lo) and np.isfinite(hi) else " [no interval]")
    return f"{row['median']:{fmt}}{ci} n={int(row['repeats'])}" + (" capped" if row.get("capped") else "")


def value(x):
    """The median of a timing cell (a number, or the text cell() writes), NaN where there is none."""
    if isinstance(x, str):
        head = x.split(" ", 1)[0]
        try:
            return float(head)
        except ValueError:
            return np.nan
    return float(x) if x is not None else np.nan
