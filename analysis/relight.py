"""Real-time relighting (issue 20): tables and a plot from the records of the experiment `relight` and of the bench
list `bench-relight`, and the reproduced report's section.

relight_PRESET: per scene, a frame served from the light basis (latency p50/p99, relights per second, worst error
against a cold float64 solve) against the cold Jacobi solve to 1e-6 the report would need per frame, and a wall's
reflectivity 10% lower re-converged from the previous frame (iterations against the same solve started cold).
bench_relight_PRESET: the product with k right-hand sides (one pass over F), time per right-hand side against k."""
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from analysis import consistency, protocol, settings  # noqa: E402
from analysis.radiosity_tables import run_time, write  # noqa: E402
from analysis.records import cell, load, plots_dir, summarise, value, writing  # noqa: E402


def _col(df, name):
    return df[name] if name in df.columns else pd.Series([None] * len(df), index=df.index)


def _solved(per_frame):
    return [f for f in per_frame if f.get("kind") == "solved"]


def _timed(rows, column):
    """The timing cell (median [95% interval] n over the runs) of one column of a case's records."""
    return cell(summarise(rows.assign(t=rows[column].astype(float)), ["scene_id"], "t").iloc[0])


def _wall(rows):
    """Mean warm iterations, mean cold iterations, solved-frame p50 ms (a cell over runs) and worst error of wall-frame
    records, and the solved frames within the budget over all of its runs."""
    if rows.empty:
        return None
    warm, cold, within, solved = [], [], 0, 0
    for _, r in rows.iterrows():
        fr = _solved(r["result.per_frame"])
        budget = r.get("params.frame_budget_ms")
        budget = float(budget) if budget is not None and budget == budget else float("inf")
        warm += [f["iterations"] for f in fr if "cold_iterations" in f]
        cold += [f["cold_iterations"] for f in fr if "cold_iterations" in f]
        within += sum(f.get("status") == "converged" and f.get("ms", float("inf")) <= budget for f in fr)
        solved += len(fr)
    return dict(warm=np.mean(warm) if warm else np.nan, cold=np.mean(cold) if cold else np.nan,
                p50=_timed(rows, "result.latency_solved.p50_ms"), worst=rows["result.worst_error"].max(),
                within=within, solved=solved)


def scenes_table(preset):
    df = load("relight", preset)
    if df.empty:
        return None
    cmd = _col(df, "params.command")
    rel, cold = df[cmd == "relight"], df[cmd == "solve"]
    rows = []
    for sid in sorted(set(rel["scene_id"].dropna())):
        r = rel[rel["scene_id"] == sid]
        mixes = r[_col(r, "params.random_frames").notna()]
        walls = r[_col(r, "params.frames").notna()]
        row = {"scene": int(sid), "patches": int(r["params.patches"].iloc[0])}
        if len(mixes):
            solved = r[_col(r, "result.basis.loaded") == False]  # noqa: E712 (the runs that solved the basis)
            p50 = _timed(mixes, "result.latency_basis.p50_ms")
            row.update(lights=len(mixes["result.lights"].iloc[-1]),
                       basis_steps=solved["result.basis.iterations"].iloc[-1] if len(solved) else "—",
                       basis_s=_timed(solved, "result.basis.seconds") if len(solved) else "—", frame_p50_ms=p50,
                       frame_p99_ms=_timed(mixes, "result.latency_basis.p99_ms"), relights_per_s=1e3 / value(p50),
                       worst_error=mixes["result.worst_error"].max())
        c = cold[cold["scene_id"] == sid]
        if len(c):
            t = run_time(c)
            row.update(cold_solve_s=cell(summarise(c.assign(t=t), ["scene_id"], "t").iloc[0]),
                       cold_iters=int(c["result.iterations"].median()))
            consistency.quote(f"scene {int(sid)}: Jacobi solve to 1e-6, run time (setup + solve, s)",
                              f"Relighting ({preset}), scene {int(sid)}, cold_solve_s", t, c)
            if "frame_p50_ms" in row:
                row["cold_over_frame"] = value(row["cold_solve_s"]) * 1e3 / value(row["frame_p50_ms"])
        for label, sel in (("jacobi", (walls["params.method"] == "jacobi") & (walls["params.ff_precision"] == "float32")),
                           ("bicgstab", walls["params.method"] == "bicgstab")):
            w = _wall(walls[sel])
            if w:
                row[f"{label}_warm_over_cold"] = w["warm"] / w["cold"]
        w = _wall(walls[walls["params.ff_precision"] == "float16"])
        if w:
            row.update(f16_1e3_p50_ms=w["p50"], f16_within_budget=f"{w['within']}/{w['solved']}")
        rows.append(row)
    t = pd.DataFrame(rows)
    notes = ["A basis frame is the mix of one float64 solution per light (one thread, rendering excluded); its error is "
             "the largest |B - B_ref| over the largest |B_ref| against a cold float64 solve (1e-12) of the same "
             "emissions, every 20th frame, the worst over all runs. Each time is the median [95% interval] n over "
             "the case's runs of the run's own figure (frame_p50_ms: the median frame of a run; basis_s: the runs "
             "that solved the basis rather than loaded it, — where every run loaded it). cold_solve_s: Jacobi to 1e-6 in float from RRV's start, the solve a frame "
             "would need without the basis, timed as Table 4.2 times a run (setup + solve; median [95% interval] n). *_warm_over_cold: iterations of the wall frames (a wall's reflectivity "
             "times 0.9, then back) started from the previous frame's B, over the same solve started cold, to 1e-4. "
             "f16: Jacobi with F in float16 to 1e-3 under a 50 ms budget; within budget: the solved frames that "
             "converged within it, over all runs (a frame stopped by the budget is not). Times are this machine's, under whatever else ran on it."]
    return write("relight", preset, f"Relighting ({preset})", t, [*notes, settings.line(df, preset), protocol.note(df["file"])])


def bench_table(preset):
    df = load("bench-relight", preset)
    if df.empty or "params.bench_rhs" not in df.columns:
        return None, None
    b = df[df["params.bench_rhs"].notna()].copy()
    if b.empty:
        return None, None
    # records from before --storage read dense F
    b["params.storage"] = b["params.storage"].fillna("dense") if "params.storage" in b.columns else "dense"
    t = b.groupby(["params.storage", "params.ff_precision", "params.bench_rhs"]).agg(
        product_ms=("result.product_ms_median", "median"), single_ms=("result.single_product_ms_median", "median"),
        gbps=("result.bandwidth_GBps", "median"),
        alt=("result.over_k1_alternating", "median")).reset_index()
    t.columns = ["storage", "ff_precision", "k", "product_ms", "single_product_ms", "read_GBps", "over_k1_alternating"]
    t["k"] = t["k"].astype(int)
    t["per_rhs_ms"] = t["product_ms"] / t["k"]
    one = t[t["k"] == 1].set_index(["storage", "ff_precision"])["product_ms"]
    t["over_k1"] = [r.product_ms / one.get((r.storage, r.ff_precision), np.nan) for r in t.itertuples()]
    spread = summarise(b, ["params.storage", "params.ff_precision", "params.bench_rhs"], "result.product_ms_median")
    t["product_ms [95%] n"] = [cell(r) for _, r in spread.iterrows()]  # the same groups, in the same order
    t["per_rhs_low"], t["per_rhs_high"] = spread["ci_low"].to_numpy() / t["k"], spread["ci_high"].to_numpy() / t["k"]
    notes = ["One pass over room3's F for k right-hand sides of three channels each, median of 10 timed products: "
             "k = 1, the solvers' product (affine_matvec) over F in the storage of the row; k >= 2, linalg.hpp's "
             "multi_affine_matvec over F's row blocks (row_blocks.hpp, built from that storage: the same blocks "
             "whatever the storage; records from before commit 7bfc79c read the storage itself). read_GBps: the bytes "
             "the product reads (F, or its row blocks) over its time; single_product_ms: the solvers' product on the "
             "same F beside it; over_k1: the k-product's time over the k = 1 case's (separate runs); "
             "over_k1_alternating: over the k = 1 product timed in turns with it in the same run (the ratio that holds "
             "on a shared machine). The issue asks for <= 2.5 at k = 8."]
    text = write("bench_relight", preset, f"Product with k right-hand sides, room3 ({preset})",
                 t.drop(columns=["per_rhs_low", "per_rhs_high"]), notes)
    return text, t


def plot(preset, t):
    if t is None or not writing():
        return None
    fig, ax = plt.subplots(figsize=(5.5, 3.8))
    for i, ((st, prec), g) in enumerate(t.groupby(["storage", "ff_precision"])):
        g = g.sort_values("k")
        multi, one = g[g["k"] >= 2], g[g["k"] == 1]
        def bars(x):
            return [(x["per_rhs_ms"] - x["per_rhs_low"]).fillna(0).clip(lower=0).to_numpy(),
                    (x["per_rhs_high"] - x["per_rhs_ms"]).fillna(0).clip(lower=0).to_numpy()]
        line = ax.errorbar(multi["k"], multi["per_rhs_ms"], yerr=bars(multi), fmt="o-", capsize=3,
                           label=f"F {st} {prec}: k-product over row blocks")
        if len(one):  # k = 1 is another kernel (the solvers' product): a point of its own, not joined to the line
            ax.errorbar(one["k"], one["per_rhs_ms"], yerr=bars(one), fmt="s", mfc="none", capsize=3,
                        color=line[0].get_color(), label=f"F {st} {prec}: k = 1, the solvers' product")
    ax.set_xscale("log", base=2)
    ax.set_xlabel("right-hand sides k")
    ax.set_ylabel("ms per right-hand side")
    ax.set_title("One pass over room3's F for k right-hand sides\n(median over runs, bars its 95% interval)",
                 fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    plots_dir().mkdir(parents=True, exist_ok=True)
    path = plots_dir() / f"bench_relight_{preset}.png"
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def write_all(preset):
    text, t = bench_table(preset)
    return {"relight": scenes_table(preset), "bench_relight": text, "bench_relight_plot": plot(preset, t)}


def report_section(preset, include, image):
    """The reproduced report's section on relighting (analysis/report.py adds it)."""
    return ["## Real-time relighting (issue 20)", "",
            "The report's §3.6 computes the form factors once because they do not change with lighting or "
            "reflectivity. B is linear in E: with F and the reflectivities fixed, any mix of the lights' intensities "
            "and colours is the same mix of one solution per light (`bin/radiosity relight`, its light basis), so a "
            "frame costs O(patches x lights) instead of a solve. A reflectivity change needs a solve, started from the "
            "previous frame's B. `bin/radiosity web` writes a page that relights in the browser from the same basis.",
            "", include("relight", preset), include("bench_relight", preset),
            image("bench_relight", preset, "Time per right-hand side against k"), ""]
