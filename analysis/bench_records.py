"""The records of `make bench` (analysis.bench, analysis.bench_sparse): one machine's records, their medians and
intervals, the bandwidth limit measured next to a case, and the target lines, each decided by the claims' one rule
(analysis/verdict.py) on an interval: a paired ratio where the target compares two solvers that ran in the same
rounds, else the interval of the median of the one quantity the target bounds."""
import math

import pandas as pd

from analysis import verdict
from analysis.records import coverage, median_ci


def on_host(df, host):
    return df[df["provenance.host"] == host] if len(df) else df


def median_of(df, col):
    return float(df[col].median())


def ci_of(df, col, scale=1.0):
    """The interval of the median of df[col] (times scale), as "[lo, hi]" with its true coverage where that is below
    95%; empty below 3 repeats."""
    v = df[col].dropna() * scale
    if len(v) < 3:
        return ""
    cov = coverage(len(v))
    return "[{:.3g}, {:.3g}]".format(*median_ci(v)) + (f" {cov:.0%}" if cov < 0.95 else "")


class Interval:
    """A quantity's median and interval, and how it was made (one sample, or paired per round)."""

    def __init__(self, value, low, high, n, how):
        self.value, self.low, self.high, self.n, self.how = value, low, high, n, how

    @classmethod
    def of(cls, values, scale=1.0):
        v = [float(x) * scale for x in values if x == x]
        lo, hi = median_ci(v) if v else (float("nan"), float("nan"))
        cov = f"{coverage(len(v)):.0%}" if len(v) >= 2 else "no interval"
        return cls(float(pd.Series(v).median()) if v else float("nan"), lo, hi, len(v), f"{cov}, n={len(v)}")

    @classmethod
    def paired(cls, a, b, col, scale=1.0):
        """The paired ratio a / b of col (analysis/verdict.py), or None where they share no round."""
        p = verdict.paired(a, b, col)
        if not p.n:
            return None
        return cls(p.ratio * scale, p.low * scale, p.high * scale, p.n, p.text().split("(", 1)[1].rstrip(")"))


def target(label, iv, threshold, expect, unit="", margin=None, exact=False):
    """One target line: label, the interval, the target and the one rule's verdict (exact: a count, whose margin is
    0; else the margin of the claims)."""
    if margin is None:
        from analysis import claims
        margin = 0.0 if exact else claims.margin()
    v = verdict.decide(iv.low, iv.high, expect, threshold, margin)
    op = ">=" if expect == "greater" else "<="
    fmt = (lambda x: f"{x:g}") if exact else (lambda x: f"{x:.3g}" if math.isfinite(x) else "nan")
    return (f"{label}: {fmt(iv.value)}{unit} [{fmt(iv.low)}, {fmt(iv.high)}] ({iv.how}; target {op} "
            f"{threshold:g}{unit}): {v}")


def limit_next_to(stream, recs, col="perf.triad_GBps"):
    """The bandwidth (the triad, or col) measured next to a case's records: the median of the last stream record at
    or before their first and the first at or after their last (either alone where the other is missing)."""
    t, first, last = stream["provenance.utc"], recs["provenance.utc"].min(), recs["provenance.utc"].max()
    near = [s for s in (stream[t <= first].sort_values("provenance.utc").tail(1),
                        stream[t >= last].sort_values("provenance.utc").head(1)) if len(s)]
    return median_of(pd.concat(near), col)
