"""Speed against accuracy (issue 6) from the accuracy-* and extremes records: error against time per scene with its
Pareto front, the cheapest setting that reaches 1%, 0.1% and 0.01% error, room3's form-factor memory in dense and
CSR storage, and the extremes' outcomes.

The error of a solve is its record's result.error_vs_reference: max over patches and channels of |B - B_ref|, over
the largest |B_ref|, B_ref a float64 solution converged to 1e-12 on the run's form factors before threshold and
rounding (tolerance, steps, precision, threshold sweeps), on a finer hemicube's (accuracy-hemicube), or on the
finest mesh's, carried onto the run's mesh by area-weighted means (accuracy-mesh). Two families, two panels: the
solver's settings cost solve time; the form factors' settings cost hemicube time too."""
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import LogLocator  # noqa: E402
import pandas as pd  # noqa: E402

from analysis import settings  # noqa: E402
from analysis.extremes import extreme_outcomes, extremes  # noqa: E402
from analysis.radiosity_tables import write  # noqa: E402
from analysis.records import cell, load, median_ci, plots_dir, summarise  # noqa: E402

SOLVER_SWEEPS = ("accuracy-tolerance", "accuracy-precision", "accuracy-threshold")
FF_SWEEPS = ("accuracy-hemicube", "accuracy-mesh")
TARGETS = (1e-2, 1e-3, 1e-4)
MARKERS = {"accuracy-tolerance": "o", "accuracy-precision": "s", "accuracy-threshold": "^", "accuracy-hemicube": "D",
           "accuracy-mesh": "v"}
# Below this an error is rounding, not a setting's cost: it is drawn here so that log axes can show it.
ERROR_FLOOR = 1e-12


def setting(r):
    """A solve's setting in words: what its sweep varies."""
    sweep = r["experiment"]
    prec = r["params.precision"]
    stop = f"{int(r['params.steps'])} steps" if r["params.steps"] > 0 else f"tol {r['params.tol']:.0e}"
    if sweep == "accuracy-tolerance":
        return f"{r['params.method']} {stop} {prec}"
    if sweep == "accuracy-precision":
        return f"{prec}, F {r['params.ff_precision']}, {stop}"
    if sweep == "accuracy-threshold":
        return f"{r['params.storage']} threshold {r['params.threshold']:g}"
    if sweep == "accuracy-hemicube":
        return f"hemicube R={int(r['params.hemicube'])}"
    return f"divide {r['params.divide']:g} ({int(r['params.patches'])} patches)"


def hemicube_times(preset):
    """Seconds the hemicube took for each form-factor file (by file name), from the accuracy-formfactors records."""
    ff = load("accuracy-formfactors", preset)
    if ff.empty:
        return {}
    ff["name"] = ff["result.file"].map(lambda f: Path(f).name)
    return ff.groupby("name")["times_s.hemicube"].median().to_dict()


def solves(preset):
    """Every accuracy solve as one row per setting: median time over repeats, its error, its sweep and scene."""
    frames = []
    for sweep in SOLVER_SWEEPS + FF_SWEEPS:
        df = load(sweep, preset)
        if df.empty:
            continue
        df = df[df["params.command"] == "solve"].copy()
        df["experiment"] = sweep
        frames.append(df)
    if not frames:
        return pd.DataFrame()
    df = pd.concat([f.dropna(axis=1, how="all") for f in frames], ignore_index=True)
    df["setting"] = df.apply(setting, axis=1)
    df["measured_s"] = df["times_s.setup"] + df["times_s.solve"]
    df["time_s"] = solver_time(df)
    df = df.join(time_interval(df))
    hemi = hemicube_times(preset)
    in_ff = df["experiment"].isin(FF_SWEEPS)
    for c in ("time_s", "time_lo", "time_hi"):
        df.loc[in_ff, c] += df.loc[in_ff, "params.ff_file"].map(lambda f: hemi.get(Path(f).name, np.nan))
    df["scene"] = df["params.scene"].map(lambda s: Path(s).stem)
    g = df.groupby(["scene", "experiment", "setting"], sort=False)
    out = g.agg(time_s=("time_s", "median"), measured_s=("measured_s", "median"),
                error=("result.error_vs_reference", "median"),
                iterations=("result.iterations", "median"), status=("result.status", "first"),
                method=("params.method", "first"), precision=("params.precision", "first"),
                tol=("params.tol", "first"), steps=("params.steps", "first"), storage=("params.storage", "first"),
                ff_precision=("params.ff_precision", "first"), threshold=("params.threshold", "first"),
                hemicube=("params.hemicube", "first"), divide=("params.divide", "first"),
                patches=("params.patches", "first"), repeats=("time_s", "size"), time_lo=("time_lo", "first"),
                time_hi=("time_hi", "first"), time_n=("time_n", "first")).reset_index()
    out["family"] = np.where(out["experiment"].isin(FF_SWEEPS), "form factors", "solver")
    out.attrs["settings"] = settings.line(df[df["scene"].isin(swept_scenes(out))], preset)
    return out


# What costs the same per iteration: one solver configuration of one sweep on one scene.
CONFIG = ["experiment", "params.scene", "params.method", "params.precision", "params.ff_precision", "params.storage",
          "params.threshold", "params.omega", "params.ff_file", "params.divide"]
TIME_NOTE = ("Solver settings: time = the configuration's median setup + iterations x its median time per iteration "
             "(each a median over every run of that method, precision and storage in the sweep, one run per setting), "
             "so that more iterations never take less time for noise of one millisecond-long run; the measured "
             "time of each run is in the CSV (measured_s).")


def solver_time(df):
    """setup + iterations x time per iteration, each the median over the runs of the row's configuration (CONFIG):
    a sweep runs each setting once, and a single run of a few milliseconds is mostly noise."""
    cols = [c for c in CONFIG if c in df.columns]
    keys = df[cols].astype(str).agg("|".join, axis=1)
    per_it = (df["times_s.solve"] / df["result.iterations"].where(df["result.iterations"] > 0)).groupby(keys).transform("median")
    setup = df["times_s.setup"].groupby(keys).transform("median")
    modelled = setup + df["result.iterations"] * per_it
    return modelled.where(modelled.notna(), df["measured_s"])


def time_interval(df):
    """Per row, the interval and n of its modelled time: the distribution-free interval of the median over the runs j of
    its configuration of setup_j + the row's iterations x time per iteration_j (NaN below 3 runs)."""
    cols = [c for c in CONFIG if c in df.columns]
    keys = df[cols].astype(str).agg("|".join, axis=1)
    per_it = df["times_s.solve"] / df["result.iterations"].where(df["result.iterations"] > 0)
    lo, hi, n = [], [], []
    for i, k in zip(df.index, keys):
        mine = keys == k
        vals = (df.loc[mine, "times_s.setup"] + df.loc[i, "result.iterations"] * per_it[mine]).dropna()
        ci = median_ci(vals) if len(vals) >= 3 else (np.nan, np.nan)
        lo.append(ci[0])
        hi.append(ci[1])
        n.append(len(vals))
    return pd.DataFrame({"time_lo": lo, "time_hi": hi, "time_n": n}, index=df.index)


def is_default(r, hemicube):
    """The report's default run: Jacobi to 1e-6 in float on dense float32 form factors at the preset's hemicube."""
    if r["family"] == "solver":
        return (r["experiment"] == "accuracy-tolerance" and r["method"] == "jacobi" and r["steps"] == 0 and
                r["precision"] == "float" and math.isclose(r["tol"], 1e-6))
    return r["experiment"] == "accuracy-hemicube" and r["hemicube"] == hemicube


def pareto(points):
    """The settings no other beats in both time and error, by increasing time."""
    front, best = [], math.inf
    for _, r in points.sort_values(["time_s", "error"]).iterrows():
        if r["error"] < best:
            front.append(r)
            best = r["error"]
    return pd.DataFrame(front)


def preset_hemicube(preset):
    ff = load("formfactors", preset)
    return int(ff["params.hemicube"].median()) if not ff.empty else None


def swept_scenes(df):
    """Scenes with the tolerance sweep: the others (room3 in the quick preset) have only their storage table."""
    return sorted(set(df.loc[df["experiment"] == "accuracy-tolerance", "scene"]))


def plot(preset, df):
    hemicube = preset_hemicube(preset)
    plots_dir().mkdir(parents=True, exist_ok=True)
    made = []
    for scene, d in df[df["scene"].isin(swept_scenes(df))].groupby("scene"):
        fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
        for ax, family in zip(axes, ("solver", "form factors")):
            f = d[(d["family"] == family) & d["error"].notna()].copy()
            if f.empty:
                ax.text(0.5, 0.5, f"no {family} sweep for {scene} in this preset", transform=ax.transAxes,
                        ha="center")
                ax.set_axis_off()
                continue
            f["shown"] = f["error"].clip(lower=ERROR_FLOOR)
            for sweep, s in f.groupby("experiment"):  # x bars: the 95% interval of the modelled time
                xerr = [(s["time_s"] - s["time_lo"]).fillna(0).clip(lower=0),
                        (s["time_hi"] - s["time_s"]).fillna(0).clip(lower=0)]
                ax.errorbar(s["time_s"], s["shown"], xerr=xerr, fmt=MARKERS[sweep], ms=5, alpha=0.8, capsize=2,
                            elinewidth=0.8, label=sweep.replace("accuracy-", ""))
            front = pareto(f)
            ax.step(front["time_s"], front["shown"], where="post", color="k", lw=1, label="Pareto front")
            dflt = f[f.apply(lambda r: is_default(r, hemicube), axis=1)]
            if len(dflt):
                ax.scatter(dflt["time_s"], dflt["shown"], marker="*", s=220, facecolor="none", edgecolor="red",
                           lw=1.5, label="report's default", zorder=5)
            for t in TARGETS:
                ax.axhline(t, color="grey", lw=0.5, ls=":")
            ax.set_xscale("log")
            ax.set_yscale("log")
            for axis in (ax.xaxis, ax.yaxis):  # a tick at every decade
                axis.set_major_locator(LogLocator(base=10, numticks=40))
            ax.set_xlabel("setup + iterations x time per iteration (s)" if family == "solver"
                          else "hemicube + setup + iterations x time per iteration (s)")
            ax.set_ylabel("max relative error against the reference")
            ax.set_title(f"{scene}: {family} settings")
            ax.grid(alpha=0.3, which="both", lw=0.3)
            ax.legend(fontsize=7)
        fig.suptitle(f"Speed against accuracy ({preset}): {scene}")
        fig.tight_layout()
        out = plots_dir() / f"accuracy_pareto_{scene}_{preset}.png"
        fig.savefig(out, dpi=110)
        plt.close(fig)
        made.append(out)
    return made


def cheapest(preset, df):
    rows = []
    for (scene, family), d in df[df["scene"].isin(swept_scenes(df))].groupby(["scene", "family"]):
        for t in TARGETS:
            ok = d[d["error"] <= t].sort_values("time_s")
            row = {"scene": scene, "settings": family, "target error": f"{t:.0e}"}
            if len(ok):
                best = ok.iloc[0]
                row.update({"cheapest setting": best["setting"], "time (s)": time_cell(best), "error": best["error"]})
            else:
                row.update({"cheapest setting": "none reaches it", "time (s)": "—", "error": np.nan})
            rows.append(row)
    table = pd.DataFrame(rows)
    return write("accuracy_cheapest", preset, f"Cheapest setting that reaches each error ({preset})", table, [
        TIME_NOTE + " Error against the converged float64 solution on the same form factors. Form-factor "
        "settings: time = hemicube + the solve's time as above, error against the finest hemicube or mesh of the "
        "sweep. One thread per solve in the quick preset. time (s): median [95% interval] n, the interval and n "
        "those of its configuration's runs (setup + the setting's iterations x each run's time per iteration).",
        df.attrs.get("settings", "")])


def time_cell(r):
    """A setting's modelled time as a timing cell: median [interval] n=runs of its configuration."""
    return cell({"median": r["time_s"], "ci_low": r["time_lo"], "ci_high": r["time_hi"], "repeats": r["time_n"],
                 "capped": False})


def sweeps_table(preset, df):
    cols = ["scene", "experiment", "setting", "iterations", "status", "time_s", "measured_s", "repeats", "error"]
    t = df[cols].rename(columns={"experiment": "sweep", "time_s": "time (s)", "measured_s": "measured (s)",
                                 "repeats": "its runs"})
    t["time (s)"] = [time_cell(r) for _, r in df.iterrows()]
    return write("accuracy_sweeps", preset, f"Every setting of the speed-against-accuracy sweeps ({preset})", t,
                 [TIME_NOTE + " time (s): median [95% interval] n, the interval and n those of its configuration's "
                  "runs; measured: the median of the setting's own runs (its runs: their count).", df.attrs.get("settings", "")])


def room3_storage(preset):
    df = load("accuracy-threshold", preset)
    if df.empty:
        return None
    df = df[df["params.scene"].map(lambda s: Path(s).name) == "room3.xml"]
    if df.empty:
        return None
    g = df.groupby(["params.threshold", "params.storage"]).agg(
        patches=("params.patches", "first"), kept=("result.kept", "median"), density=("result.density", "median"),
        mb=("result.matrix_storage_bytes", "median"), peak=("perf.peak_rss_bytes", "median"),
        build=("times_s.ff_build", "median"), solve=("times_s.solve", "median"),
        iterations=("result.iterations", "median"), error=("result.error_vs_reference", "median")).reset_index()
    keys = ["params.threshold", "params.storage"]
    for col, what in (("build", "times_s.ff_build"), ("solve", "times_s.solve")):
        cells = {(r["params.threshold"], r["params.storage"]): cell(r) for r in summarise(df, keys, what).to_dict("records")}
        g[col] = [cells.get(k, "—") for k in zip(g["params.threshold"], g["params.storage"])]
    table = pd.DataFrame({
        "threshold": g["params.threshold"].map(lambda x: f"{x:g}"), "storage": g["params.storage"],
        "kept F_ij": g["kept"].astype(int), "density": g["density"], "F in memory (MB)": g["mb"] / 1e6,
        "peak RSS (MB)": g["peak"] / 1e6, "build (s)": g["build"], "Jacobi iterations": g["iterations"].astype(int),
        "solve (s)": g["solve"], "error": g["error"]})
    return write("accuracy_room3_storage", preset, f"room3.xml: form factors in dense and CSR storage ({preset})",
                 table, ["Jacobi to 1e-6 in float; error against the float64 solution converged to 1e-12 on the "
                         "unthresholded form factors. Peak RSS includes the form-factor file's dense float32 "
                         "values, which every run reads whole before building CSR. build, solve: median [95% "
                         "interval] n=runs (no interval below 3 runs).", settings.line(df, preset)])


def write_all(preset):
    df = solves(preset)
    made = {"accuracy_room3_storage": room3_storage(preset), "extremes": extremes(preset)}
    if df.empty:
        made.update(accuracy_pareto=None, accuracy_cheapest=None)
        return made
    made["accuracy_pareto"] = plot(preset, df) or None
    made["accuracy_cheapest"] = cheapest(preset, df)
    made["accuracy_sweeps"] = sweeps_table(preset, df)
    return made


def report_section(preset, include, image):
    """The reproduced report's section "Speed against accuracy" (analysis/report.py adds it)."""
    df = solves(preset)
    scenes = swept_scenes(df) if not df.empty else []
    out = ["## Speed against accuracy", "",
           "Every solve of the accuracy sweeps carries its error against a float64 solution converged to 1e-12: on "
           "the same form factors for the solver's settings (tolerance, fixed steps, precision, form factors in "
           "16 bits, threshold), on the finest hemicube or mesh for the form factors' settings. Error is the "
           "largest |B - B_ref| over the patches and channels, over the largest |B_ref|. The red star is the "
           "report's default (Jacobi to 1e-6 in float, dense float32 F, the preset's hemicube); the black line, "
           "the settings no other beats in both time and error.", ""]
    for s in scenes:
        out.append(image(f"accuracy_pareto_{s}", preset, f"Speed against accuracy, {s}"))
    out += [include("accuracy_cheapest", preset), include("accuracy_room3_storage", preset),
            "### Extremes", "", *extreme_outcomes(preset), "",
            "- a form-factor matrix whose rows sum to 1.5 with rho = 1: Jacobi (and RRV's loop) stop with status "
            "divergent within 30 steps, exit status 3 and one line (tests/integration/test_reliability.py, "
            "test_accuracy.py: dense and CSR). BiCG-STAB is not guarded: I - rho F is still non-singular, and it "
            "converges in one iteration to B = E/(1 - 1.5) = -2E, a negative radiosity, with exit status 0 (the "
            "closed box of radiosity/scenes/closed_box.xml with rho = 1 and its R = 32 form factors times 1.5)",
            "- zero emission: the residual is measured absolutely (its scale is 1), B = 0 is converged at step 0 "
            "(tests/unit/solve/test_extremes.cpp)", "", include("extremes", preset)]
    return out
