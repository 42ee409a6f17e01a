"""The extremes (issue 6): closed boxes near rho = 1, emissions of 1e30 and 1e-30, tiny and huge boxes, and Poisson
CG at N = 1, 2 and 1024, each run once; closed boxes at rho = 1, 1.05 and 1.2 (issue 54), whose light is amplified
and which have no physical answer, every method in both precisions; their outcomes (exit status and reason, a float
run stopped before its tolerance flagged) as a table and in sentences for the report. Below rho = 1 the table sets the
exact answer of the stored F, E / (1 - rho s) with s its rows' sum (from the form factors' own record), beside
E / (1 - rho)."""
import math
from pathlib import Path

import numpy as np
import pandas as pd

from analysis import protocol, settings
from analysis.escape import md
from analysis.radiosity_tables import write
from analysis.records import NONE_USED, load


def row_sums(preset):
    """{form-factor file: the middle of its rows' sums} from the form factors' records (accuracy-formfactors)."""
    ff = load("accuracy-formfactors", preset)
    if ff.empty or "result.file" not in ff:
        return {}
    return {f: 0.5 * (lo + hi) for f, lo, hi in zip(ff["result.file"], ff["result.min_row_sum"], ff["result.max_row_sum"])
            if isinstance(f, str)}


def far_from(r, exact):
    """The largest relative distance of a run's radiosity (its smallest and largest) from `exact`."""
    if not isinstance(r.get("result.radiosity_max"), list) or not np.isfinite(exact):
        return np.nan
    return max(abs(x - exact) for x in (r["result.radiosity_min"] + r["result.radiosity_max"])) / exact


def rho_of(scene):
    """The reflectivity of a closed box named box_rhoX.xml; NaN for any other scene."""
    name = Path(scene).stem
    return float(name[len("box_rho"):]) if name.startswith("box_rho") else np.nan


def extremes(preset):
    df = load("extremes", preset)
    if df.empty:
        return None
    rows = []
    rad = df[df["app"] == "radiosity"]
    sums = row_sums(preset)
    for _, r in rad.iterrows():
        name = Path(r["params.scene"]).stem
        rho = 0.5 if np.isnan(rho_of(r["params.scene"])) else rho_of(r["params.scene"])  # the other boxes: 0.5
        emission = float(name[len("box_emission"):]) if name.startswith("box_emission") else 1.0
        s = sums.get(r.get("params.ff_file"), np.nan)
        exact = emission / (1 - rho) if rho < 1 else np.nan  # rho >= 1: no physical answer
        stored = emission / (1 - rho * s) if rho < 1 and rho * s < 1 else np.nan
        b = r.get("result.radiosity_max")
        steps = math.log(r["params.tol"]) / math.log(rho) if r["params.method"] == "jacobi" and rho < 1 else np.nan
        rows.append({"case": name, "method": r["params.method"], "precision": r["params.precision"],
                     "outcome": outcome(r), "iterations": r["result.iterations"],
                     "log(tol)/log(rho)": steps,
                     "B": r["result.radiosity_max"][0] if isinstance(b, list) else np.nan, "E/(1-rho)": exact,
                     "E/(1-rho s)": stored, "error vs E/(1-rho s)": far_from(r, stored),
                     "error vs E/(1-rho)": far_from(r, exact), "error vs converged F": r.get("result.error_vs_reference"),
                     "time (s), one run (n=1)": r["times_s.solve"]})
    for _, r in df[df["app"] == "poisson"].iterrows():
        rows.append({"case": f"poisson N={int(r['params.n'])}", "method": "cg", "precision": r["params.precision"],
                     "outcome": outcome(r), "iterations": r["result.iterations"],
                     "B": np.nan, "E/(1-rho)": np.nan,
                     "error vs E/(1-rho)": np.nan, "error vs converged F": np.nan,
                     "true residual": r.get("result.true_rel_residual"), "max |u - u_h|": r.get("result.error_inf"),
                     "time (s), one run (n=1)": r["times_s.solve"]})
    table = pd.DataFrame(rows)
    return write("extremes", preset, f"Extremes ({preset})", table, [settings.line(df, preset), protocol.note(df["file"]),
        "Closed boxes: 192 patches, hemicube R = 256, whose rows sum to s within about 1e-5 of 1, so the exact answer "
        "of their F is E/(1 - rho s) (s: the middle of the rows' sums its form factors' record gives), and "
        "E/(1 - rho) is off by about rho (s - 1)/(1 - rho). At rho = 1 and above the light is amplified, not "
        "absorbed: no physical answer exists, and every method in both precisions must end with no answer (exit 3, "
        "or 4 at --max-iter), never 0; an answer below E is refused as unphysical. Poisson: CG to 1e-6, "
        "error against the exact solution u = sin^2(pi x) sin^2(pi y). outcome: \"answer\" for exit status 0, else "
        "\"no answer\" with the exit status (3 numerical failure, 4 not converged within --max-iter, 5 disagreed with "
        "its float64 check) and the run's own reason; a float run that stopped before its tolerance is flagged "
        "\"stopped before tol\" whatever its exit status. Each case ran once: its time is one run's solve (n=1, no "
        "interval)."])


def outcome(r):
    """A run's outcome in words: its exit status and reason, and a flag where it stopped before its tolerance."""
    status = str(r.get("result.status"))
    text = "answer (exit 0)" if r["exit_status"] == 0 else \
        f"no answer (exit {int(r['exit_status'])}: {r.get('result.exit_reason') or status})"
    if status != "converged":
        text += f", stopped before tol ({status})"
    return text


def extreme_outcomes(preset):
    """The extremes' outcomes in words, from the records."""
    df = load("extremes", preset)
    if df.empty:
        return [f"No extremes records used for this preset ({NONE_USED})."]
    lines = []
    rad = df[df["app"] == "radiosity"]
    rhos = rad["params.scene"].map(rho_of)
    box = rad[(rad["params.method"] == "jacobi") & (rhos < 1)]
    def answered(r):  # a run that is no answer (exit 3, 4, 5) has no radiosity to quote: its reason instead
        return isinstance(r.get("result.radiosity_max"), list)

    def no_answer(r, what):
        return (f"- {what}: no answer, exit status {int(r.get('result.exit_status', 0))} after "
                f"{r['result.iterations']} iterations: {md(r.get('result.exit_reason', r['result.status']))}")

    for _, r in box.sort_values(["params.scene", "params.precision"]).iterrows():
        rho = rho_of(r["params.scene"])
        if not answered(r):
            lines.append(no_answer(r, f"closed box rho = {rho:g}, Jacobi in {r['params.precision']} to "
                                      f"{r['params.tol']:g}"))
            continue
        b = r["result.radiosity_max"][0]
        lines.append(f"- closed box rho = {rho:g}, Jacobi in {r['params.precision']} to {r['params.tol']:g}: "
                     f"{md(r['result.status'])} after {r['result.iterations']} steps (log(tol)/log(rho) = "
                     f"{math.log(r['params.tol']) / math.log(rho):.0f}), B = {b:.6g} against E/(1 - rho) = "
                     f"{1 / (1 - rho):.6g} ({abs(b * (1 - rho) - 1):.2%} off: the hemicube's row sums), "
                     f"{r['result.error_vs_reference']:.2g} from the converged solution of the same F")
    amplified = rad[rhos >= 1]
    for scene, g in amplified.groupby("params.scene", sort=True):
        rho = rho_of(scene)
        answered_too = [f"{r['params.method']} in {r['params.precision']}" for _, r in g.iterrows() if answered(r)]
        by = g.groupby("exit_status").size()
        lines.append(f"- closed box rho = {rho:g} (the light amplified: no physical answer), {len(g)} runs, every "
                     f"method in both precisions: " + ", ".join(f"{n} exit {int(k)}" for k, n in by.items()) +
                     (f"; AN ANSWER WAS GIVEN by {md(', '.join(answered_too))}" if answered_too else "; none gave an "
                      "answer") + ". " + "; ".join(sorted({md(str(r.get('result.status'))) + ": " +
                                                          md(str(r.get('result.exit_reason', '')))[:120]
                                                          for _, r in g.iterrows() if r["params.method"] == "bicgstab"
                                                          and r["params.precision"] == "double"})))
    for _, r in rad[rhos.isna()].iterrows():
        if not answered(r):
            lines.append(no_answer(r, md(f"{Path(r['params.scene']).stem}, {r['params.method']} in {r['params.precision']}")))
            continue
        lines.append(f"- {md(Path(r['params.scene']).stem)}, {md(r['params.method'])} in {md(r['params.precision'])}: "
                     f"{md(r['result.status'])} after {r['result.iterations']} iterations, B = "
                     f"{r['result.radiosity_min'][0]:.6g} ... {r['result.radiosity_max'][0]:.6g}, "
                     f"{r['result.error_vs_reference']:.2g} from the converged solution")
    for _, r in df[df["app"] == "poisson"].iterrows():
        lines.append(f"- Poisson CG N = {int(r['params.n'])} in {md(r['params.precision'])}: {md(r['result.status'])} after "
                     f"{r['result.iterations']} iterations, recursive residual {r['result.rel_residual']:.2g}, true "
                     f"residual {r['result.true_rel_residual']:.2g}, max |u - u_h| = {r['result.error_inf']:.3g}")
    return lines
