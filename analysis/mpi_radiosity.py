"""Radiosity across nodes (issue 9) from the mpi-formfactors, mpi-radiosity and mpi-large records: how the time and
the memory of a rank grow with the patches n and the ranks P.

Every MPI record carries per-rank lists (record key "mpi"): rows held, bytes of F held (4 n rows), peak resident
memory, and for solves the bytes received per iteration and the seconds in MPI calls; for form factors the seconds
each rank's hemicube took. Series: "strong" (one scene, P = 1, 2, ...), "weak" (patches growing as sqrt(P), so
that n²/P, a rank's share of F, stays about constant), "large" (a scene one rank may not hold), and "one process"
(backend openmp beside the strong series)."""
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from analysis import protocol, settings  # noqa: E402
from analysis.escape import md, md_table  # noqa: E402
from analysis.records import cell, load, plots_dir, summarise, tables_dir  # noqa: E402

MIB = 2.0 ** 20


def series(path):
    name = str(path)
    if name.endswith("-rows.ff"):
        return "strong, equal-count split"
    if "mpi-weak" in name:
        return "weak"
    if "mpi-large" in name:
        return "large"
    return "strong"


def _max(v):
    return float(np.max(v)) if isinstance(v, (list, np.ndarray)) and len(v) else np.nan


def records(preset):
    """(form-factor records, solve records) of the three experiments, one row per run, with the columns below."""
    frames = [load(e, preset) for e in ("mpi-formfactors", "mpi-radiosity", "mpi-large")]
    frames = [f.dropna(axis=1, how="all") for f in frames if not f.empty]
    if not frames:
        return pd.DataFrame(), pd.DataFrame()
    df = pd.concat(frames, ignore_index=True).copy()
    df["ranks"] = df["params.ranks"].fillna(1).astype(int) if "params.ranks" in df.columns else 1
    df["n"] = df["params.patches"].astype(int)
    df["n2_per_rank_M"] = df["n"] ** 2 / df["ranks"] / 1e6
    for col, src in (("F per rank MiB", "mpi.rank_ff_bytes"), ("peak RSS per rank MiB", "mpi.rank_peak_rss_bytes")):
        df[col] = df[src].map(_max) / MIB if src in df.columns else np.nan
    if "perf.peak_rss_bytes" in df.columns:  # one process: its own peak
        one = df["F per rank MiB"].isna()
        df.loc[one, "peak RSS per rank MiB"] = df.loc[one, "perf.peak_rss_bytes"] / MIB
    ff = df[df["params.command"] == "formfactors"].copy()
    sv = df[df["params.command"] == "solve"].copy()
    if not ff.empty:
        ff["series"] = ff["result.file"].map(series)
        ff.loc[ff["F per rank MiB"].isna(), "F per rank MiB"] = 4 * ff["n"] ** 2 / MIB
    if not sv.empty:
        sv["series"] = sv["params.ff_file"].map(series)
        sv.loc[sv["params.backend"] != "mpi", "series"] = "one process"
        sv.loc[sv["F per rank MiB"].isna(), "F per rank MiB"] = 4 * sv["n"] ** 2 / MIB
        sv["comm share"] = [(_max(c) / s if s > 0 else np.nan) if isinstance(c, list) else 0.0
                            for c, s in zip(sv.get("mpi.rank_comm_s", pd.Series([None] * len(sv), index=sv.index)),
                                            sv["times_s.solve"])]
        sv["received KiB/it per rank"] = (sv["mpi.rank_received_bytes_per_iteration"].map(_max) / 1024
                                          if "mpi.rank_received_bytes_per_iteration" in sv.columns else np.nan)
    return ff, sv


def with_interval(t, df, keys, src, col, scale=1.0):
    """t with the 95% interval of the median of df[src] per keys beside its column col (col lo, col hi, col n,
    col capped), scaled like col: the csv keeps them, the markdown shows them in one cell (shown)."""
    s = summarise(df.assign(_v=df[src] * scale), keys, "_v")
    s = s.rename(columns={"ci_low": f"{col} lo", "ci_high": f"{col} hi", "repeats": f"{col} n",
                          "capped": f"{col} capped"})
    return t.merge(s[keys + [f"{col} lo", f"{col} hi", f"{col} n", f"{col} capped"]], on=keys, how="left")


def shown(t, cols):
    """The markdown view of t: each of cols as median [95% interval] n=runs, its interval columns and runs dropped."""
    t = t.copy()
    for c in cols:
        t[c] = [cell({"median": m, "ci_low": lo, "ci_high": hi, "repeats": n, "capped": cap}, ".4g")
                for m, lo, hi, n, cap in zip(t[c], t[f"{c} lo"], t[f"{c} hi"], t[f"{c} n"], t[f"{c} capped"])]
        t = t.drop(columns=[f"{c} lo", f"{c} hi", f"{c} n", f"{c} capped"])
    return t.drop(columns=["runs"])


def formfactor_table(ff):
    keys = ["series", "n", "ranks"]
    g = ff.groupby(keys, dropna=False)
    t = g.agg(**{"hemicube s": ("times_s.hemicube", "median"), "n²/P (M)": ("n2_per_rank_M", "first"),
                 "F per rank MiB": ("F per rank MiB", "max"), "peak RSS per rank MiB": ("peak RSS per rank MiB", "max"),
                 "runs": ("times_s.hemicube", "size")}).reset_index()
    if "mpi.hemicube_imbalance" in ff.columns:
        t["imbalance (max/mean)"] = g["mpi.hemicube_imbalance"].median().values
    if "mpi.rank_write_s" in ff.columns:
        t["write s (slowest rank)"] = g["mpi.rank_write_s"].agg(lambda s: np.median([_max(v) for v in s])).values
    base = t[(t["series"] == "strong") & (t["ranks"] == 1)]["hemicube s"]
    t["speedup vs P=1"] = np.where(t["series"] == "strong", base.iloc[0] / t["hemicube s"] if len(base) else np.nan,
                                   np.nan)
    t = with_interval(t, ff, keys, "times_s.hemicube", "hemicube s")
    return t.sort_values(["series", "n", "ranks"])


def solve_table(sv):
    keys = ["series", "params.method", "n", "ranks"]
    g = sv.groupby(keys, dropna=False)
    t = g.agg(**{"iterations": ("result.iterations", "median"), "ms/iteration": ("times_s.per_iteration", "median"),
                 "solve s": ("times_s.solve", "median"), "n²/P (M)": ("n2_per_rank_M", "first"),
                 "F per rank MiB": ("F per rank MiB", "max"),
                 "received KiB/it per rank": ("received KiB/it per rank", "max"),
                 "time in MPI (share)": ("comm share", "median"),
                 "peak RSS per rank MiB": ("peak RSS per rank MiB", "max"),
                 "agreed": ("verify.agreed", "all"), "runs": ("times_s.solve", "size")}).reset_index()
    t["ms/iteration"] *= 1e3
    t = with_interval(t, sv, keys, "times_s.per_iteration", "ms/iteration", 1e3)
    t = with_interval(t, sv, keys, "times_s.solve", "solve s")
    return t.rename(columns={"params.method": "method"}).sort_values(["series", "method", "n", "ranks"])


def growth_notes(ff, sv):
    """What the records say about growth, in words with the numbers."""
    notes = []
    s = sv[(sv["series"] == "strong") & (sv["params.method"] == "jacobi")] if not sv.empty else sv
    if len(s):
        m = s.groupby("ranks").agg(ff=("F per rank MiB", "max"), t=("times_s.per_iteration", "median"),
                                   rss=("peak RSS per rank MiB", "max"))
        lo, hi = m.index.min(), m.index.max()
        notes.append(f"Strong scaling (Jacobi, {int(s['n'].iloc[0])} patches): F per rank {m.ff[lo]:.1f} MiB at "
                     f"P = {lo}, {m.ff[hi]:.1f} MiB at P = {hi} (4n²/P), peak resident memory per rank {m.rss[lo]:.0f} → "
                     f"{m.rss[hi]:.0f} MiB; time per iteration {m.t[lo] * 1e3:.3g} → {m.t[hi] * 1e3:.3g} ms.")
    w = sv[(sv["series"] == "weak")] if not sv.empty else sv
    if len(w):
        m = w.groupby("ranks").agg(n=("n", "first"), ff=("F per rank MiB", "max"),
                                   t=("times_s.per_iteration", "median"))
        notes.append("Weak scaling (Jacobi, n²/P about constant): " + "; ".join(
            f"P = {p}: {int(r.n)} patches, F per rank {r.ff:.1f} MiB, {r.t * 1e3:.3g} ms/iteration"
            for p, r in m.iterrows()) + ".")
    both = pd.concat([x for x in (ff, sv) if not x.empty])
    base = (both["peak RSS per rank MiB"] - both["F per rank MiB"]).median()
    notes.append(f"Peak resident memory per rank = F per rank + about {base:.0f} MiB that does not depend on n or P "
                 "here (the program and its libraries, the mesh, the vectors: O(n)); F, 4n²/P, is what grows.")
    f = ff[ff["series"] == "strong"] if not ff.empty else ff
    if len(f):
        m = f.groupby("ranks")["times_s.hemicube"].median()
        notes.append("Form factors (strong): hemicube " + ", ".join(f"{v:.3g} s at P = {p}" for p, v in m.items()) +
                     " (time ∝ n²/P: every row renders all n patches).")
    eq = ff[ff["series"] == "strong, equal-count split"] if not ff.empty else ff
    if len(eq) and len(f):
        p = int(eq["ranks"].iloc[0])
        w = f[f["ranks"] == p]
        if len(w) and "mpi.hemicube_imbalance" in ff.columns:
            notes.append(f"Split at P = {p}: blocks of equal estimated work {w['times_s.hemicube'].median():.3g} s "
                         f"(slowest / mean rank {w['mpi.hemicube_imbalance'].median():.2f}), blocks of equal count "
                         f"{eq['times_s.hemicube'].median():.3g} s ({eq['mpi.hemicube_imbalance'].median():.2f}).")
    return notes


def _bars(ax, g, col, scale, fmt, label):
    """The median of g[col] per rank count, its 95% interval as error bars."""
    m = summarise(g.assign(_v=g[col] * scale), ["ranks"], "_v").sort_values("ranks")
    err = [(m["median"] - m["ci_low"]).fillna(0).clip(lower=0), (m["ci_high"] - m["median"]).fillna(0).clip(lower=0)]
    ax.errorbar(m["ranks"], m["median"], yerr=err, fmt=fmt, capsize=3, label=label)


def plot(ff, sv, preset):
    plots_dir().mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    ax = axes[0]
    for (ser, meth), g in sv[sv["series"].isin(["strong", "weak"])].groupby(["series", "params.method"]):
        _bars(ax, g, "times_s.per_iteration", 1e3, "o-" if ser == "strong" else "s--", f"{meth}, {ser}")
    ax.set_xlabel("MPI ranks P")
    ax.set_ylabel("ms per iteration (median, bars: 95% interval)")
    ax.set_title("solve: time per iteration")
    ax.legend(fontsize=7)
    ax = axes[1]
    if len(ff):
        for ser, g in ff[ff["series"].isin(["strong", "weak"])].groupby("series"):
            _bars(ax, g, "times_s.hemicube", 1.0, "o-" if ser == "strong" else "s--", ser)
        ax.legend(fontsize=7)
    ax.set_xlabel("MPI ranks P")
    ax.set_ylabel("hemicube s (slowest rank)")
    ax.set_title("form factors: time")
    ax = axes[2]
    for ser, g in sv[sv["series"].isin(["strong", "weak"])].groupby("series"):
        m = g.groupby("ranks")[["F per rank MiB", "peak RSS per rank MiB"]].max()
        ax.plot(m.index, m["F per rank MiB"], "o-" if ser == "strong" else "s--", label=f"F held, {ser}")
        ax.plot(m.index, m["peak RSS per rank MiB"], "o:" if ser == "strong" else "s:", label=f"peak RSS, {ser}")
    ax.set_xlabel("MPI ranks P")
    ax.set_ylabel("MiB per rank (largest rank)")
    ax.set_title("memory per rank")
    ax.legend(fontsize=7)
    both = pd.concat([x for x in (ff, sv) if not x.empty])
    cores = int(both["provenance.cpus_online"].min()) if "provenance.cpus_online" in both.columns else 0
    ranks = sorted(set(both["ranks"]))
    for a in axes:
        a.grid(alpha=0.3)
        a.set_xticks(ranks)
        if cores and cores < max(ranks):  # past here ranks share cores: their times measure oversubscription
            a.axvline(cores + 0.5, ls=":", color="grey")
            a.text(cores + 0.55, 0.97, "ranks > cores", transform=a.get_xaxis_transform(), fontsize=7, va="top",
                   color="grey")
    fig.suptitle(f"Radiosity across MPI ranks ({preset})")
    fig.tight_layout()
    fig.savefig(plots_dir() / f"mpi_radiosity_{preset}.png", dpi=110)
    plt.close(fig)


def write_table(preset):
    ff, sv = records(preset)
    if ff.empty and sv.empty:
        return None
    tables_dir().mkdir(parents=True, exist_ok=True)
    out = [f"### Radiosity across MPI ranks ({preset})", ""]
    frames = []
    if not ff.empty:
        t = formfactor_table(ff)
        frames.append(t.assign(command="formfactors"))
        out += ["Form factors (`mpirun -np P bin/radiosity formfactors`): hemicube time of the slowest rank, F and "
                "peak resident memory of the largest rank; times: median [95% interval of the median] n=runs.", "",
                md_table(shown(t, ["hemicube s"])), ""]
    if not sv.empty:
        t = solve_table(sv)
        frames.append(t.assign(command="solve"))
        out += ["Solves to 1e-6 (`--backend mpi`; \"one process\": openmp), float, AOS; received: the other ranks' "
                "rows of every vector gathered, per iteration, on the rank that receives most; times: median [95% "
                "interval of the median] n=runs.", "", md_table(shown(t, ["ms/iteration", "solve s"])), ""]
        plot(ff, sv, preset)
    hosts = sorted(set(pd.concat([ff, sv])["provenance.host"]))
    files = pd.concat([ff, sv])["file"] if "file" in pd.concat([ff, sv]) else []
    notes = growth_notes(ff, sv) + [settings.line(pd.concat([ff, sv]), preset), protocol.note(files),
        f"Records from {md(', '.join(map(str, hosts)))}; P ranks with one OpenMP thread each. Where P exceeds the cores "
        "(provenance.cpus_online), ranks share cores: times past that count measure oversubscription; the memory "
        "per rank does not depend on it."]
    out += [f"- {n}" for n in notes]
    pd.concat(frames, ignore_index=True).to_csv(tables_dir() / f"mpi_radiosity_{preset}.csv", index=False)
    text = "\n".join(out).replace(" nan ", " — ") + "\n"
    (tables_dir() / f"mpi_radiosity_{preset}.md").write_text(text)
    return text


def report_section(preset, include, image):
    return ["## Radiosity across nodes (MPI)", "",
            "Form factors and solves on MPI ranks, each rank its block of rows of F (`mpirun -np P bin/radiosity "
            "formfactors`, `solve --backend mpi`): the dense F takes 4n² bytes, so a rank holds 4n²/P, and a scene "
            "whose F exceeds one node's memory runs on enough nodes (slurm/mpi-large.sbatch). Every MPI solve is "
            "checked against float64 on the same ranks; the tests check it against one process within 1e-6.", "",
            include("mpi_radiosity", preset), image("mpi_radiosity", preset, "time and memory per rank against P")]
