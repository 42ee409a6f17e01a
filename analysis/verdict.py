"""The one rule that decides every claim part of the report and every target of make bench (issue 49), and the
paired ratio it is applied to. No verdict is written anywhere else, and none is replaced afterwards: what our
setting changes, or why a part cannot run here, is said beside the verdict.

The rule, for a claim that a ratio A / B lies above a threshold t (expect "greater"; "less" for below it), with a
margin m (MARGIN, or the machine's measured drift from run to run where that is larger):
  confirmed   the interval of the ratio lies above t (1 + m)        (below t / (1 + m) for "less")
  refuted     the interval lies on the other side: below t / (1 + m) (above t (1 + m) for "less")
  equivalent  the interval lies within [t / (1 + m), t (1 + m)]
  undecided   otherwise (the interval reaches across the margin's edge)
  not run     no interval: this machine has no runs of a side
The interval is the distribution-free interval of the median (common/timing_protocol.py: median_ci) of the paired
ratios A_r / B_r, one per round r in which both ran; its true coverage, below 95% for fewer than 6 pairs, is given
with it."""
import math

import numpy as np
import pandas as pd

from analysis.protocol import timing_protocol as tp

VERDICTS = ("confirmed", "refuted", "equivalent", "undecided", "not run")
MARGIN = 0.05


def decide(low, high, expect="greater", threshold=1.0, margin=MARGIN):
    """The rule above; low, high: the interval of the ratio."""
    if not (low is not None and high is not None and math.isfinite(low) and math.isfinite(high)) or low > high:
        return "not run"
    up, down = threshold * (1 + margin), threshold / (1 + margin)
    above, below = low > up, high < down
    if expect == "less":
        above, below = below, above
    if above:
        return "confirmed"
    if below:
        return "refuted"
    if low >= down and high <= up:
        return "equivalent"
    return "undecided"


class Paired:
    """A paired ratio: per-round ratios a_r / b_r, their median, its interval and true coverage, the pairs' count,
    and whether every pair ran interleaved (in the same round of one block: slurm/run-local)."""

    def __init__(self, ratios, interleaved):
        self.ratios = [float(x) for x in ratios if np.isfinite(x) and x > 0]
        self.n = len(self.ratios)
        self.interleaved = interleaved and self.n > 0
        self.ratio = tp.median(self.ratios) if self.n else float("nan")
        self.low, self.high = tp.median_ci(self.ratios) if self.n else (float("nan"), float("nan"))
        self.coverage = tp.coverage(self.n) if self.n >= 2 else float("nan")

    def text(self):
        if not self.n:
            return "no pairs"
        cov = f"{self.coverage:.0%}" if self.n >= 2 else "no interval, one pair"
        how = "interleaved" if self.interleaved else "paired by repeat, not interleaved"
        return f"{self.ratio:.3g} [{self.low:.3g}, {self.high:.3g}] ({cov}, {self.n} pairs, {how})"


def sides(df, value="time_s"):
    """A side of a comparison, from a frame of runs: its value per round (provenance.env.HPCGI_REPEAT, the median
    where a round holds several runs), and its block per round (protocol.block, None where the state file names
    none)."""
    if df is None or len(df) == 0:
        return pd.Series(dtype=float), pd.Series(dtype=object)
    rep = df["provenance.env.HPCGI_REPEAT"].map(lambda r: int(r) if str(r).isdigit() else None) \
        if "provenance.env.HPCGI_REPEAT" in df else pd.Series(None, index=df.index)
    d = pd.DataFrame({"rep": rep, "v": pd.to_numeric(df[value], errors="coerce"),
                      "block": df["protocol.block"] if "protocol.block" in df else None}).dropna(subset=["rep", "v"])
    return d.groupby("rep")["v"].median(), d.groupby("rep")["block"].first()


def paired(a, b, value="time_s"):
    """The paired ratio a / b of two frames of runs (their rounds in common)."""
    (va, ba), (vb, bb) = sides(a, value), sides(b, value)
    common = sorted(set(va.index) & set(vb.index))
    ratios = [va[r] / vb[r] for r in common if vb[r] > 0]
    inter = all(ba.get(r) is not None and isinstance(ba.get(r), str) and ba.get(r) == bb.get(r) for r in common)
    return Paired(ratios, inter)
