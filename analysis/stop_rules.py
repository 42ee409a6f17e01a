"""The stopping rules of `bin/radiosity solve --stop`, as radiosity/solve/config/stop_rule.cpp computes them,
evaluated on a record's residual history (result.history): the Table 4.2 audit (analysis/table42_audit.py) replays
every run's stop with them."""
import math

import numpy as np

TOL = 1e-6


def parse_rule(name):
    base, *mods = name.split("+")
    return base, "stacked" in mods, "squared" in mods


def _arr(v):
    """A list of per-channel lists (None: not known) as a float array, NaN for None."""
    return np.array([[np.nan if x is None else x for x in row] for row in v], dtype=float)


def rule_values(h, name):
    """The rule's value for every iterate of history h (a record's result.history)."""
    base, stacked, squared = parse_rule(name)
    e2, r02 = np.array(h["e2"], dtype=float), np.array(h["r0_2"], dtype=float)
    res2, step2, b2 = _arr(h["res2"]), _arr(h["step2"]), _arr(h["b2"])
    step_inf, b_inf = _arr(h["step_inf"]), _arr(h["b_inf"])
    k = len(res2)
    num, den = {
        "residual-e": (res2, np.tile(e2, (k, 1))),
        "residual-r0": (res2, np.tile(r02, (k, 1))),
        "residual-b": (res2, b2),
        "step-2": (step2, b2),
        "step-inf": (step_inf ** 2, b_inf ** 2),
    }[base]

    def one_if_zero(d):
        return np.where(d == 0, 1.0, d)

    with np.errstate(invalid="ignore", divide="ignore"):
        if stacked:
            if base == "step-inf":  # the largest channel; NaN stays NaN (np.max propagates it)
                n, d = np.max(num, axis=1), np.max(den, axis=1)
            else:
                n, d = num.sum(axis=1), den.sum(axis=1)
            v = np.sqrt(n / one_if_zero(d))
        else:
            v = np.sqrt(num / one_if_zero(den))
            v = np.where(np.isnan(v).any(axis=1), np.nan, np.max(v, axis=1))
    return v ** 2 if squared else v


def replay(h, name, tol=TOL):
    """The first iteration whose rule value is <= tol (None: none in this history)."""
    v = rule_values(h, name)
    hits = np.nonzero(v <= tol)[0]
    return int(h["iteration"][hits[0]]) if len(hits) else None


def tol_interval(h, name, count):
    """The tolerances for which `name` stops this history at exactly `count`: [v_count, min_{k<count} v_k)."""
    v = rule_values(h, name)
    it = list(h["iteration"])
    if count not in it:
        return None
    i = it.index(count)
    before = v[:i][~np.isnan(v[:i])]
    if np.isnan(v[i]):
        return None
    return v[i], (before.min() if len(before) else math.inf)
