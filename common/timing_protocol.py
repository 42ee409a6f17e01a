#!/usr/bin/env python3
"""The timing protocol's one definition of a group's spread and of when a timed case has run enough (Hoefler and
Belli, SC15: a non-parametric interval of the median, repeated until it is tight, disturbed runs kept out).

The interval of a median is distribution-free: the order statistics [x_(k), x_(n+1-k)] of the sorted values, k the
largest whose coverage, 1 - 2 P(Binomial(n, 1/2) <= k - 1), is at least the level asked (the sign test's interval;
scipy.stats.binom gives the same tail). It holds for any distribution of the runs, skewed or with outliers, and its
coverage is exact: where n is too small for the level ([min, max] of 3 runs covers the median 75% of the time, of 5
runs 94%), `coverage` says what it is, and the tables print it instead of a "95%" the count cannot give. A paired
comparison's per-round ratios take the same interval.

A timed case (a case list whose "# repeat: N" is above 1, or that has none) runs in rounds with the other cases of
its block (slurm/run-local: the experiments whose claims compare their cases, "# block: NAME" in their lists): every
case's repeat r before any case's repeat r + 1, the order reversed from one round to the next, so that a change of
load falls on all of them alike and the cases a claim compares are paired in each round. After round N (the list's
repeat count, at least LEAST: what a 95% interval needs), a case stops as soon as the 95% interval of its median lies
within +-5% of the median, counting only its answers (exit status 0) that were not disturbed (common/timed_run.py:
the machine's state beside each run); else it goes on to the cap (REPEAT_CAP, default 2N + 1), once it holds at
least N undisturbed answers (rounds past the cap replace disturbed runs, up to twice the cap). Its state file then
gets one line saying which of the two happened.

    common/timing_protocol.py decide RECORDS STATE CASE ROUND MIN CAP [HARD]
        prints "continue", "interval", "cap" or "no-answer" (HARD, default 2 x CAP: the last round in any case);
        on all but "continue" appends the group's line
        {"case", "stop", "n", "median_s", "ci_s", "coverage"} to STATE.

analysis/records.py takes median_ci from here, so the runner's stopping rule and the tables' intervals agree.
Standard library only: it runs where the project's virtual environment is not."""
import json
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # the repository or the kit
from common import harness_io  # noqa: E402  (the one way to open a harness file)

LEVEL = 0.95
TARGET = 0.05  # the interval's half-width, relative to the median
LEAST = 6  # the least count of a timed group: the fewest runs whose interval of the median reaches 95% (96.9%)
# The time that a case's group is judged on, as the tables show it: a solve's setup + solve (+ upload to a GPU: the
# run time of analysis/radiosity_tables.py and table41.py), else the first of these in a record's times_s.
TIMED = ("hemicube", "total")


def median(values):
    v = sorted(values)
    n = len(v)
    return float("nan") if n == 0 else v[n // 2] if n % 2 else 0.5 * (v[n // 2 - 1] + v[n // 2])


def _order(n, level):
    """(k, coverage): the order statistic k (1-based) of the interval [x_(k), x_(n+1-k)] and its exact coverage."""
    k, cover = 1, 1 - 2 * 0.5 ** n  # [min, max]
    tail = 0.0  # P(Binomial(n, 1/2) <= j - 1), accumulated
    for j in range(1, n // 2 + 1):
        tail += math.comb(n, j - 1) * 0.5 ** n
        c = 1 - 2 * tail
        if c >= level:
            k, cover = j, c
        else:
            break
    return k, cover


def coverage(n, level=LEVEL):
    """The true coverage of median_ci's interval for n values (below `level` where n is too small for it)."""
    return _order(n, level)[1] if n >= 2 else float("nan")


def median_ci(values, level=LEVEL):
    """The distribution-free interval of the median of `values` at `level` (or the widest the count allows, [min,
    max], whose coverage `coverage` gives); NaNs for no values, (x, x) for one."""
    v = sorted(float(x) for x in values)
    n = len(v)
    if n == 0:
        return float("nan"), float("nan")
    if n == 1:
        return v[0], v[0]
    k, _ = _order(n, level)
    return v[k - 1], v[n - k]


def interval_met(values, target=TARGET):
    """Whether the interval of the median lies within +-target of the median."""
    if len(values) < 2:
        return False
    m = median(values)
    lo, hi = median_ci(values)
    return m > 0 and (m - lo) <= target * m and (hi - m) <= target * m


def timed_value(rec):
    t = rec.get("times_s") or {}
    if isinstance(t.get("solve"), (int, float)) and isinstance(t.get("setup"), (int, float)):
        return float(t["setup"] + t["solve"] + (t.get("upload") or 0))
    for k in TIMED:
        if isinstance(t.get(k), (int, float)):
            return float(t[k])
    return None


def read_lines(path):
    """The JSON objects of a records or state file (a line that is none is left out; harness_io names it)."""
    good, _ = harness_io.read_objects(path)
    return [d for _, d in good]


def group(records_path, state_path, case):
    """(times of the case's answers that were not disturbed, whether any run was no answer)."""
    disturbed = {int(s["repeat"]) for s in read_lines(state_path)
                 if s.get("case") == case and s.get("disturbed") and isinstance(s.get("repeat"), int)}
    times, no_answer = [], False
    for r in read_lines(records_path):
        env = (r.get("provenance") or {}).get("env") or {}
        if env.get("HPCGI_CASE") != case:
            continue
        if (r.get("result") or {}).get("exit_status", 0) != 0:
            no_answer = True
            continue
        t = timed_value(r)
        if t is not None and str(env.get("HPCGI_REPEAT", "")).isdigit() and int(env["HPCGI_REPEAT"]) not in disturbed:
            times.append(t)
    return times, no_answer


def decide(records_path, state_path, case, rnd, least, cap, hard=None):
    times, no_answer = group(records_path, state_path, case)
    if no_answer:
        stop = "no-answer"
    elif rnd >= least and len(times) >= least and interval_met(times):
        stop = "interval"
    elif rnd >= cap and (len(times) >= least or rnd >= (hard or 2 * cap)):
        stop = "cap"  # at the cap, once the group holds enough undisturbed answers (at most HARD rounds)
    else:
        return "continue"
    lo, hi = median_ci(times) if times else (None, None)
    line = json.dumps({"case": case, "stop": stop, "n": len(times), "median_s": median(times) if times else None,
                       "ci_s": [lo, hi] if times else None,
                       "coverage": round(coverage(len(times)), 4) if len(times) >= 2 else None}, sort_keys=True)
    harness_io.append_line(state_path, line)  # whole or not at all; HarnessFileError says why
    return stop


def main(argv):
    if len(argv) not in (7, 8) or argv[0] != "decide":
        print(__doc__.split("\n\n")[2] if argv[:1] in (["-h"], ["--help"]) else
              "usage: common/timing_protocol.py decide RECORDS STATE CASE ROUND MIN CAP [HARD]",
              file=sys.stdout if argv[:1] in (["-h"], ["--help"]) else sys.stderr)
        return 0 if argv[:1] in (["-h"], ["--help"]) else 2
    _, records, state, case, rnd, least, cap, *hard = argv
    try:
        rnd, least, cap, hard = int(rnd), int(least), int(cap), int(hard[0]) if hard else None
    except ValueError:
        print("timing_protocol: ROUND, MIN, CAP and HARD must be integers", file=sys.stderr)
        return 2
    try:
        print(decide(records, state, case, rnd, least, cap, hard))
    except harness_io.HarnessFileError as e:
        print(f"timing_protocol: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
