"""The claims (issue 49): one rule with a margin decides every part on paired per-round ratios; the interval of a
median is distribution-free and means its level (a coverage test on skewed samples); the order statistics are the
binomial's (scipy.stats, a reference we did not write); no verdict is written outside analysis/verdict.py; every claim
of the seed is a row, GPU ones *not run* here with what would decide them; BiCG-STAB's is decided on every scene."""
import re
import sys

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from conftest import ROOT

sys.path.insert(0, str(ROOT))
from analysis import claims, verdict  # noqa: E402
from analysis.protocol import timing_protocol as tp  # noqa: E402


def test_the_rule_decides_by_the_interval_and_the_margin():
    assert verdict.decide(1.10, 1.30) == "confirmed"
    assert verdict.decide(0.70, 0.90) == "refuted"
    assert verdict.decide(0.97, 1.03) == "equivalent"
    assert verdict.decide(0.99, 1.20) == "undecided"
    assert verdict.decide(1.04, 1.20) == "undecided"  # beyond 1, not beyond the margin
    assert verdict.decide(1.04, 1.20, margin=0.02) == "confirmed"
    assert verdict.decide(0.70, 0.90, expect="less") == "confirmed"
    assert verdict.decide(1.10, 1.30, expect="less") == "refuted"
    assert verdict.decide(3.6, 4.6, threshold=4.0) == "undecided"  # a bench target of 4x: its interval holds 4
    assert verdict.decide(float("nan"), float("nan")) == "not run"
    assert verdict.decide(None, None) == "not run"


def test_the_interval_of_a_median_is_the_binomials_order_statistics():
    for n in range(2, 40):
        k, cov = tp._order(n, 0.95)
        # coverage of [x_(k), x_(n+1-k)] = P(k <= B <= n - k), B ~ Binomial(n, 1/2)
        exact = stats.binom.cdf(n - k, n, 0.5) - stats.binom.cdf(k - 1, n, 0.5)
        assert abs(cov - exact) < 1e-12, (n, k, cov, exact)
        wider_ok = k == 1 or exact >= 0.95
        assert wider_ok and (k + 1 > n // 2 or stats.binom.cdf(n - k - 1, n, 0.5) - stats.binom.cdf(k, n, 0.5) < 0.95)
    assert tp.coverage(3) == 0.75 and tp.coverage(6) > 0.95 and tp.coverage(5) < 0.95
    assert tp.median_ci([3, 1, 2]) == (1, 3)


@pytest.mark.parametrize("kind", ["lognormal", "outliers"])
def test_the_interval_covers_the_true_median_at_least_as_often_as_it_says(kind):
    """Skewed samples at n = 3..20: the share of intervals that hold the true median is at least the stated coverage
    (the level where the count reaches it, else its true coverage) less one point."""
    rng = np.random.default_rng(2026)
    trials = 4000
    # a run in ten a far outlier, 20x: the median of that mixture, found once by sampling it
    true_mix = float(np.median(np.where(rng.random(2_000_000) < 0.1, 20, 1) * rng.normal(1.0, 0.05, 2_000_000)))
    for n in range(3, 21):
        if kind == "lognormal":
            x = rng.lognormal(0.0, 1.0, size=(trials, n))
            true = 1.0  # exp(0)
        else:
            base = rng.normal(1.0, 0.05, size=(trials, n))
            x = np.where(rng.random((trials, n)) < 0.1, 20 * base, base)
            true = true_mix
        hit = 0
        for row in x:
            lo, hi = tp.median_ci(row)
            hit += lo <= true <= hi
        stated = 0.95 if tp.coverage(n) >= 0.95 else tp.coverage(n)  # the level, or the count's true coverage
        assert hit / trials >= stated - 0.01, (kind, n, hit / trials, stated)


def frame(times_a, times_b, block="radiosity-cpu"):
    rows = []
    for side, times in (("a", times_a), ("b", times_b)):
        for r, t in enumerate(times):
            rows.append({"side": side, "time_s": t, "provenance.env.HPCGI_REPEAT": str(r), "protocol.block": block})
    df = pd.DataFrame(rows)
    return df[df["side"] == "a"], df[df["side"] == "b"]


def test_a_part_is_decided_on_per_round_ratios_which_cancel_what_both_sides_share():
    """The rounds' drift (a factor 1.5 from one round to the next, as a neighbour comes and goes) is in both sides of
    every pair: per-round ratios stay 2.0 and decide, where the two sides' medians from different minutes would not."""
    drift = np.array([1.0, 1.5, 1.0, 1.5, 1.0, 1.5, 1.0])
    a, b = frame(2.0 * drift * (1 + 0.01 * np.arange(7)), 1.0 * drift)
    p = verdict.paired(a, b)
    assert p.n == 7 and p.interleaved and abs(p.ratio - 2.06) < 1e-9 and p.low >= 2.0 and p.high <= 2.12
    row = claims.part("c", "p", a, b)
    assert row["verdict"] == "confirmed" and "7 pairs, interleaved" in row["numbers"] and "98%" in row["numbers"]
    a2, b2 = frame(list(a["time_s"]), list(b["time_s"]), block=None)
    assert "paired by repeat, not interleaved" in claims.part("c", "p", a2, b2)["numbers"]
    # three pairs: the interval is [min, max] and says it covers 75%
    a3, b3 = frame([2.0, 2.1, 1.9], [1.0, 1.0, 1.0])
    assert "75%, 3 pairs" in claims.part("c", "p", a3, b3)["numbers"]


def test_no_verdict_is_written_outside_the_one_decision_function():
    words = ("confirmed", "refuted", "equivalent", "undecided", "not separated", "not reproduced")
    found = []
    for f in sorted((ROOT / "analysis").glob("*.py")):
        if f.name == "verdict.py":
            continue
        for n, line in enumerate(f.read_text().splitlines(), 1):
            if re.search(r"""["'](%s)["']""" % "|".join(words), line):
                found.append(f"{f.name}:{n}: {line.strip()}")
    assert not found, found


def table42_frame(scenes, j_iter, b_iter, j_per, b_per, n=7):
    rows = []
    for s in scenes:
        for method, it, per in (("jacobi", j_iter, j_per), ("bicgstab", b_iter, b_per)):
            for r in range(n):
                rows.append({"scene_id": s, "params.method": method, "params.backend": "openmp",
                             "result.iterations": it, "time_s": per * it * (1 + 0.01 * r),
                             "provenance.env.HPCGI_REPEAT": str(r), "protocol.block": "radiosity-cpu"})
    return pd.DataFrame(rows)


def test_bicgstab_is_decided_on_every_scene_with_our_counts_beside_the_verdict(monkeypatch):
    monkeypatch.setattr(claims, "margin", lambda: 0.05)
    monkeypatch.setattr(claims.radiosity_tables, "solves", lambda e, p: table42_frame([1, 2, 3], 62, 12, 0.01, 0.023))
    rows = claims.bicgstab("quick")
    assert {r["part"].split(":")[0] for r in rows} == {"scene 1", "scene 2", "scene 3 (room3)"}
    time3 = [r for r in rows if r["part"] == "scene 3 (room3): time, BiCG-STAB over Jacobi"][0]
    assert time3["verdict"] == "refuted"  # 12 x 0.023 < 62 x 0.01: ours is faster, whatever the report's
    assert "our iterations (Jacobi 62, BiCG-STAB 12) are not the report's (36, 17)" in time3["note"]
    cost = [r for r in rows if r["part"].startswith("scene 3 (room3): cost")][0]
    assert cost["verdict"] == "confirmed" and "the report's 2.25" in cost["numbers"]


def test_every_claim_of_the_seed_is_a_row_gpu_ones_not_run_without_a_gpu(monkeypatch):
    empty = pd.DataFrame(columns=["scene_id", "column", "time_s", "params.backend", "params.n", "params.distribution",
                                  "provenance.env.HPCGI_REPEAT"])
    monkeypatch.setattr(claims, "margin", lambda: 0.05)
    monkeypatch.setattr(claims.radiosity_tables, "solves", lambda e, p: empty)
    monkeypatch.setattr(claims.table41, "ours", lambda p: (empty, empty))
    rows = claims.all_claims("quick")
    titles = {r["claim"] for r in rows}
    for c in ("BiCG-STAB", "OpenMP speeds up", "AOS with OpenMP", "more MPI processes", "cuBLAS 1",
              "GPU outperforms the CPU", "OpenMP beats CUDA with AOS", "cuBLAS (SOA) beats OpenMP",
              "CUDA with SOA", "hybrid improves"):
        assert any(c in t for t in titles), (c, titles)
    gpu = [r for r in rows if "needs a GPU" in r["numbers"]]
    assert len(gpu) >= 6 and all(r["verdict"] == "not run" for r in gpu)
    assert any("p4 over p8" in r["part"] and "needs 8 cores" in r["numbers"] for r in rows)
