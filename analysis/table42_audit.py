"""Table 4.2 audited (issue 21): which stopping rule and starting vector give the report's iteration counts, and
Gauss-Seidel beside Jacobi and BiCG-STAB, from the table42-audit and table42 records.

Every audit solve ran with --history: its record holds, per iterate b_k, the norms its method measured (squares of
2-norms per channel, the ∞-norms; null where not known), so `replay` evaluates any stopping rule on it exactly as
radiosity/solve/config/stop_rule.cpp does, and the tables check that each run's own count is what its history replays."""
import math

import matplotlib
import matplotlib.ticker

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from analysis import settings  # noqa: E402
from analysis.radiosity_tables import write as write_table  # noqa: E402
from analysis.records import NONE_USED, cell, load, paper_table, plots_dir, summarise, tables_dir  # noqa: E402
from analysis.stop_rules import TOL, parse_rule, replay, rule_values, tol_interval  # noqa: E402,F401  (the audit's API)

EXPERIMENT = "table42-audit"
DEFAULT_RULE = "residual-e"
SCENE_NAMES = {1: "scene1", 2: "scene2", 3: "room3", 4: "room2"}


# ---- the records --------------------------------------------------------------------------------------------------

def runs(preset):
    df = load(EXPERIMENT, preset)
    if df.empty or "params.command" not in df.columns:
        return pd.DataFrame()
    df = df[df["params.command"] == "solve"].copy()
    hist_cols = [c for c in df.columns if c.startswith("result.history.")]
    df["history"] = df[hist_cols].rename(columns=lambda c: c[len("result.history."):]).to_dict("records")
    df["weights"] = df["params.weights"]
    df["start"] = df["params.start"]
    df["method"] = df["params.method"]
    df["rule"] = df["params.stop"]
    df["threads"] = df["params.threads"]
    df["replayed"] = [replay(h, r, t) for h, r, t in zip(df["history"], df["rule"], df["params.tol"])]
    return df


def report_counts():
    p = paper_table("table42").set_index("scene")
    return {int(s): (int(p.loc[s, "jacobi_iter"]), int(p.loc[s, "bicgstab_iter"])) for s in p.index}


def rule_table(df):
    """Rule x (scene, weights, start) -> Jacobi / BiCG-STAB iterations to 1e-6 in float, as the runs counted."""
    d = df[(df["params.tol"] == TOL) & (df["params.precision"] == "float") & df["method"].isin(["jacobi", "bicgstab"])]
    d = d[d["params.omega"].isna()] if "params.omega" in d.columns else d
    rows = []
    for rule in dict.fromkeys(d["rule"]):
        row = {"rule": rule}
        for (s, w, start), g in d[d["rule"] == rule].groupby(["scene_id", "weights", "start"], sort=True):
            it = g.groupby("method")["result.iterations"].first()
            row[f"{SCENE_NAMES[s]} {w} {start}"] = f"{it.get('jacobi', np.nan):.0f} / {it.get('bicgstab', np.nan):.0f}"
        rows.append(row)
    return pd.DataFrame(rows)


def fits(df, counts):
    """(rule, weights, start) whose Jacobi and/or BiCG-STAB counts equal the report's on every audited scene."""
    d = df[(df["params.tol"] == TOL) & (df["params.precision"] == "float") & df["method"].isin(["jacobi", "bicgstab"])]
    out = {"jacobi": [], "bicgstab": [], "both": []}
    for (rule, w, start), g in d.groupby(["rule", "weights", "start"]):
        ok = {"jacobi": True, "bicgstab": True}
        for s, gs in g.groupby("scene_id"):
            for m, want in zip(("jacobi", "bicgstab"), counts.get(int(s), (None, None))):
                got = gs[gs["method"] == m]["result.iterations"]
                ok[m] = ok[m] and len(got) > 0 and want is not None and int(got.iloc[0]) == want
        for m in ("jacobi", "bicgstab"):
            if ok[m]:
                out[m].append(f"{rule} ({w}, start {start})")
        if ok["jacobi"] and ok["bicgstab"]:
            out["both"].append(f"{rule} ({w}, start {start})")
    return out


def nearest(df, counts):
    """Per method, the (rule, weights, start) whose counts are closest to the report's (sum of |ours - report|)."""
    d = df[(df["params.tol"] == TOL) & (df["params.precision"] == "float")]
    best = {}
    for m, idx in (("jacobi", 0), ("bicgstab", 1)):
        g = d[d["method"] == m].copy()
        g["off"] = [abs(int(it) - counts[int(s)][idx]) for it, s in zip(g["result.iterations"], g["scene_id"])]
        tot = g.groupby(["rule", "weights", "start"])["off"].sum().sort_values()
        if len(tot):
            best[m] = (tot.index[0], int(tot.iloc[0]))
    return best


def interval_table(df, counts):
    """For the default rule: the tolerance interval that gives exactly the report's count, from each history (Jacobi:
    the float run to 1e-6; BiCG-STAB: the double run to 1e-10, the report's 17 being past our float run's end), and
    what the other method needs at that interval's geometric middle."""
    rows = []
    d = df[df["rule"] == DEFAULT_RULE]
    for (s, w, start), g in d.groupby(["scene_id", "weights", "start"]):
        if int(s) not in counts:
            continue
        jac_n, bic_n = counts[int(s)]

        def hist(method, prec, tol):
            x = g[(g["method"] == method) & (g["params.precision"] == prec) & (g["params.tol"] == tol)]
            return x["history"].iloc[0] if len(x) else None

        jf, bd, jd = hist("jacobi", "float", TOL), hist("bicgstab", "double", 1e-10), hist("jacobi", "double", 1e-10)
        row = {"scene": SCENE_NAMES[int(s)], "weights": w, "start": start}
        ivs = []
        for label, h, n, other, name in (("jacobi", jf if jf is not None else jd, jac_n, bd, "bicgstab"),
                                         ("bicgstab", bd, bic_n, jd, "jacobi")):
            iv = tol_interval(h, DEFAULT_RULE, n) if h is not None else None
            short = (f"none: the run stops at {int(h['iteration'][-1]) - (label != 'bicgstab')} iterations "
                     f"(tol {g[g['history'].map(lambda x: x is h)]['params.tol'].iloc[0]:g})") if h is not None else "no run"
            row[f"{label} = {n} for tol in"] = short if iv is None else (
                f"[{iv[0]:.3g}, {iv[1]:.3g})" if iv[0] < iv[1] else "empty (not monotone)")
            at = None
            if iv is not None and iv[0] < iv[1] and other is not None:
                mid = math.sqrt(iv[0] * iv[1]) if math.isfinite(iv[1]) else iv[0]
                at = replay(other, DEFAULT_RULE, mid)
            row[f"{name} there"] = at
            ivs.append(iv)
        if len(ivs) == 2 and all(iv is not None and iv[0] < iv[1] for iv in ivs):
            lo, hi = max(ivs[0][0], ivs[1][0]), min(ivs[0][1], ivs[1][1])
            row["both for tol in"] = f"[{lo:.3g}, {hi:.3g})" if lo < hi else "none (disjoint)"
        rows.append(row)
    return pd.DataFrame(rows)


def gauss_seidel_table(df):
    """Gauss-Seidel beside Jacobi and BiCG-STAB to 1e-6 (default rule, float), its thread dependence, SOR."""
    d = df[(df["rule"] == DEFAULT_RULE) & (df["params.tol"] == TOL) & (df["params.precision"] == "float")]
    rows = []
    for (s, w, start), g in d.groupby(["scene_id", "weights", "start"]):
        row = {"scene": SCENE_NAMES[int(s)], "weights": w, "start": start}
        for m in ("jacobi", "bicgstab"):
            x = g[g["method"] == m]
            row[m] = int(x["result.iterations"].iloc[0]) if len(x) else None
        gs = g[g["method"] == "gauss-seidel"].sort_values("threads")
        for t, it in zip(gs["threads"], gs["result.iterations"]):
            row[f"gauss-seidel, {int(t)} thread{'s' if t > 1 else ''}"] = int(it)
        for o, it in zip(g[g["method"] == "sor"]["params.omega"], g[g["method"] == "sor"]["result.iterations"]):
            row[f"sor {o:g}"] = int(it)
        rows.append(row)
    return pd.DataFrame(rows)


def table42_with_gs(preset):
    """Table 4.2's scenes: OpenMP Jacobi, BiCG-STAB, Gauss-Seidel and SOR (one thread) (iterations, run time: median
    [95% interval] n), the fastest and its ratio to the report's OpenMP Jacobi time."""
    from analysis.radiosity_tables import solves
    df = solves("table42", preset)
    if df.empty:
        return pd.DataFrame()
    paper = paper_table("table42").set_index("scene")
    rows = []
    for s, g in df.groupby("scene_id"):
        row = {"scene": int(s), "patches": int(g["params.patches"].iloc[0])}
        times = {}
        for m in ("jacobi", "bicgstab", "gauss-seidel", "sor"):
            x = g[g["params.method"] == m]
            if len(x):
                row[f"{m} iter"] = x["result.iterations"].median()
                sm = summarise(x, ["params.method"], "time_s").iloc[0]
                row[f"{m} s"], times[m] = cell(sm), sm["median"]
        if times:
            best = min(times, key=times.get)
            row["fastest"] = best
            if int(s) in paper.index:
                row["report Jacobi s"] = paper.loc[int(s), "jacobi_s"]
                row["fastest / report Jacobi"] = times[best] / paper.loc[int(s), "jacobi_s"]
        rows.append(row)
    return pd.DataFrame(rows)


def plot(preset, df, counts):
    """Residual histories (‖e - A b‖/‖e‖, largest channel) of the deep double runs on room3 (or the preset's first
    audit scene), the report's counts marked."""
    deep = df[(df["params.tol"] == 1e-10) & (df["start"] == "rrv")]
    if deep.empty:
        return None
    s = 3 if 3 in set(deep["scene_id"]) else int(deep["scene_id"].min())
    deep = deep[deep["scene_id"] == s]
    plots_dir().mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(1, len(set(deep["weights"])), figsize=(11, 4.2), squeeze=False, sharey=True)
    for ax, (w, g) in zip(axes[0], deep.groupby("weights")):
        for m, style in (("jacobi", "-"), ("gauss-seidel", "--"), ("bicgstab", "-.")):
            x = g[g["method"] == m]
            if len(x):
                h = x["history"].iloc[0]
                th = int(x["threads"].iloc[0]) if pd.notna(x["threads"].iloc[0]) else None
                ax.semilogy(h["iteration"], rule_values(h, DEFAULT_RULE), style,
                            label=f"{m} ({th} thread{'s' if th != 1 else ''})" if th else m)
        ax.axhline(TOL, color="grey", lw=0.8)
        if s in counts:
            for n, m, c in ((counts[s][0], "report Jacobi", "C0"), (counts[s][1], "report BiCG-STAB", "C2")):
                ax.axvline(n, color=c, ls=":", lw=1.2)
                ax.text(n, 1e-9, f" {m}: {n}", color=c, rotation=90, va="bottom")
        ax.set_title(f"{SCENE_NAMES[s]}, {w} weights, start rrv (double)")
        ax.set_xlabel("iteration (BiCG-STAB: full iterations, 2 products each)")
        ax.yaxis.set_major_locator(matplotlib.ticker.LogLocator(base=10, numticks=30))
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("||e - A b|| / ||e|| (largest channel)")
    for ax in axes[0]:
        ax.legend(fontsize=8)
    fig.tight_layout()
    out = plots_dir() / f"table42_audit_{preset}.png"
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def verdict(df, counts):
    """The audit's conclusion in sentences, each from the numbers."""
    scenes = sorted(int(s) for s in set(df["scene_id"]) if int(s) in counts)
    if not scenes:
        return ["No audit records of the report's scenes 3 and 4 in this preset (ci audits scene 1)."]
    lines = []
    f = fits(df[df["scene_id"].isin(scenes)], counts)
    want = "; ".join(f"{SCENE_NAMES[s]}: Jacobi {counts[s][0]}, BiCG-STAB {counts[s][1]}" for s in scenes)
    lines.append(f"- The report's counts: {want}.")
    for m in ("jacobi", "bicgstab"):
        lines.append(f"- Rules (x weights x start) that give the report's {m} count on every audited scene: "
                     f"{', '.join(f[m]) if f[m] else 'none'}.")
    near = nearest(df[df["scene_id"].isin(scenes)], counts)
    for m, ((rule, w, start), off) in near.items():
        lines.append(f"- Closest for {m}: {rule} ({w} weights, start {start}), {off} iteration(s) off in all.")
    lines.append("- Both counts at once: " + (", ".join(f["both"]) if f["both"] else
                                                 "no rule, start and weights give the report's Jacobi and BiCG-STAB "
                                                 "counts together."))
    # Products: ours against the report's (its BiCG-STAB did about as many products as its Jacobi did steps).
    d = df[(df["rule"] == DEFAULT_RULE) & (df["params.tol"] == TOL) & (df["params.precision"] == "float")]
    for s in scenes:
        for w in sorted(set(d["weights"])):
            g = d[(d["scene_id"] == s) & (d["weights"] == w) & (d["start"] == "rrv")]
            j, b = g[g["method"] == "jacobi"], g[g["method"] == "bicgstab"]
            if len(j) and len(b):
                ours = b["perf.matrix_passes"].iloc[0] / j["result.iterations"].iloc[0]
                theirs = 2 * counts[s][1] / counts[s][0]
                lines.append(f"- {SCENE_NAMES[s]} ({w}): our BiCG-STAB makes {int(b['perf.matrix_passes'].iloc[0])} "
                             f"products against {int(j['result.iterations'].iloc[0])} Jacobi steps ({ours:.2f} per "
                             f"step); the report's 2 x {counts[s][1]} against {counts[s][0]} ({theirs:.2f}).")
    it = interval_table(df, counts)
    col_j = [c for c in it.columns if c.startswith("jacobi =")]
    col_b = [c for c in it.columns if c.startswith("bicgstab =")]
    for _, r in it.iterrows():
        if not (col_j and isinstance(r[col_j[0]], str) and r[col_j[0]].startswith("[")):
            continue
        s = next(k for k, v in SCENE_NAMES.items() if v == r["scene"])
        b = r.get("bicgstab there")
        bic = ("no BiCG-STAB run from this start" if b is None or (isinstance(b, float) and math.isnan(b)) else
               f"our BiCG-STAB stops after {int(b)} iterations there "
               f"({'the report' + chr(39) + 's count' if int(b) == counts[s][1] else 'the report: ' + str(counts[s][1])})")
        lines.append(f"- {r['scene']} ({r['weights']}, start {r['start']}): the default rule gives the report's "
                     f"Jacobi count {counts[s][0]} for tol in {r[col_j[0]]}; {bic}." +
                     (f" The report's BiCG-STAB count {counts[s][1]} needs tol in {r[col_b[0]]}, where our Jacobi "
                      f"needs {int(r['jacobi there'])}." if col_b and isinstance(r[col_b[0]], str)
                      and r[col_b[0]].startswith("[") and r.get("jacobi there") is not None
                      and not (isinstance(r.get("jacobi there"), float) and math.isnan(r["jacobi there"])) else "") +
                     (f" One tolerance for both counts: {r['both for tol in']}." if isinstance(r.get("both for tol in"), str)
                      else "") +
                     (f" No tolerance gives the report's BiCG-STAB count {counts[s][1]} ({r[col_b[0]]})."
                      if col_b and isinstance(r[col_b[0]], str) and r[col_b[0]].startswith("none") else ""))
    gs = gauss_seidel_table(df)
    for _, r in gs.iterrows() if not gs.empty else []:
        s = next(k for k, v in SCENE_NAMES.items() if v == r["scene"])
        by = {int(c.split(", ")[1].split()[0]): int(r[c]) for c in gs.columns
              if c.startswith("gauss-seidel, ") and not pd.isna(r[c])}
        if s in counts and by:
            same = [t for t, n in by.items() if n == counts[s][0]]
            lines.append(f"- {r['scene']} ({r['weights']}, start {r['start']}): Gauss-Seidel to 1e-6 takes " +
                         ", ".join(f"{n} sweeps on {t} thread{'s' if t > 1 else ''}" for t, n in sorted(by.items())) +
                         f" (Jacobi {r['jacobi']}); the report's Jacobi count {counts[s][0]} is " +
                         (f"Gauss-Seidel's on {', '.join(map(str, same))} threads." if same else
                          "none of them."))
    return lines


def write(preset):
    from analysis.radiosity_tables import solves
    t = table42_with_gs(preset)
    if not t.empty:
        write_table("table42_gs", preset, "Table 4.2 with Gauss-Seidel (OpenMP, AOS, 1e-6; run time: setup + solve)",
                    t, [settings.line(solves("table42", preset), preset, "the report's Jacobi on 16 threads"),
                        "Times: median [95% interval of the median] n=runs on this machine; the report's on one maya "
                        "node. sor: omega 1.4 on one thread (case list table42)."])
    df = runs(preset)
    if df.empty:
        return None if t.empty else t
    setting = settings.line(df, preset, "each audit solve run once (n=1): iteration counts, not times")
    counts = report_counts()
    ok = df[df["result.status"] == "converged"]
    bad = ok[ok["replayed"] != ok["result.iterations"]]
    failed = df[df["result.status"] != "converged"]
    notes = [f"Each cell: Jacobi / BiCG-STAB iterations to {TOL:g} in float, the count of the run itself; its history "
             f"replays it in {len(ok) - len(bad)} of {len(ok)} converged audit runs" +
             ("." if bad.empty else f" (not in: {', '.join(f'{r.method} {r.rule}' for r in bad.itertuples())}).") +
             ("" if failed.empty else " Not converged: " + ", ".join(
                 f"{r['method']}{' omega %g' % r['params.omega'] if r['method'] == 'sor' else ''} on "
                 f"{int(r['threads'])} threads: {r['result.status']}" for _, r in failed.iterrows()) + "."), setting]
    write_table("table42_audit_rules", preset, "Table 4.2 audited: stopping rule x start -> iterations",
                rule_table(df), notes)
    write_table("table42_audit_interval", preset, "The tolerance that gives the report's counts (default rule)",
                interval_table(df, counts), ["Rule residual-e: ||e - A b||/||e|| per channel, the largest. "
                                             "'bicgstab there', 'jacobi there': the other method's count at the "
                                             "interval's geometric middle, replayed from its history (BiCG-STAB's "
                                             "and the Jacobi column after it: the double runs to 1e-10).", setting])
    write_table("table42_audit_gs", preset, "Gauss-Seidel beside Jacobi and BiCG-STAB (default rule, 1e-6, float)",
                gauss_seidel_table(df), ["openmp Gauss-Seidel: Gauss-Seidel inside each thread's block of rows, "
                                         "Jacobi between blocks, so its count depends on the thread count.",
                                         setting])
    plot(preset, df, counts)
    (tables_dir() / f"table42_audit_verdict_{preset}.md").write_text("\n".join([*verdict(df, counts), "", setting])
                                                                     + "\n")
    return df


def fastest_lines(preset):
    """The fastest CPU method per Table 4.2 scene and its ratio to the report's OpenMP Jacobi, in sentences."""
    t = table42_with_gs(preset)
    if t.empty or "fastest" not in t.columns:
        return []
    return [f"- Scene {int(r['scene'])} ({int(r['patches'])} patches): the fastest CPU method is {r['fastest']}, "
            f"run time {r[r['fastest'] + ' s']} (seconds: median [95% interval] n), {r['fastest / report Jacobi']:.3g} times the report's OpenMP Jacobi "
            f"({r['report Jacobi s']:g} s)." for _, r in t.iterrows() if isinstance(r["fastest"], str)
            and not pd.isna(r.get("fastest / report Jacobi"))]


def report_section(preset, include, image):
    """The reproduced report's section "Table 4.2's iteration counts" (analysis/report.py adds it)."""
    df = runs(preset)
    out = ["## Table 4.2's iteration counts", "",
           "The report gives Jacobi and BiCG-STAB counts \"with a relative residual tolerance of 10^-6\" without its "
           "norm or starting vector. Each plausible reading is a stopping rule (`bin/radiosity solve --stop`: the "
           "residual ||e - A b|| over ||e||, ||r0|| or ||b||; the step ||b_k - b_k-1|| over ||b_k|| in the 2- and "
           "the inf-norm; per channel or over the stacked channels; or the value squared) and a start (`--start "
           "rrv`: max(radiosity, emission), or zero). Every run below recorded its residual history "
           "(`--history`); case list `table42-audit`.", ""]
    if df.empty:
        return out + [f"No table42-audit records used for this preset ({NONE_USED}; to run them: `slurm/run-local formfactors "
                      "table42-audit-formfactors table42-audit`).", settings.planned(EXPERIMENT, preset), "",
                      include("table42_gs", preset), *fastest_lines(preset), ""]
    counts = report_counts()
    out += ["### Verdict", "", *verdict(df, counts), "",
            settings.line(df, preset, "each audit solve run once (n=1): iteration counts, not times"), "",
            include("table42_audit_rules", preset), include("table42_audit_interval", preset),
            include("table42_audit_gs", preset), include("table42_gs", preset), *fastest_lines(preset), "",
            image("table42_audit", preset, "Residual histories with the report's counts"), ""]
    return out
