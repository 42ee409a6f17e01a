"""Table 4.1 and Figure 4.1: Poisson CG run time against N, per MPI process count and per CUDA variant, beside
the report's published numbers; and beyond the report, CG preconditioned by one multigrid V-cycle (bin/poisson
--precond mg, issue 19) in the columns "MG-PCG ..." and their curves."""
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from analysis import settings  # noqa: E402
from analysis.radiosity_tables import emit, no_gpu_note, threads_note  # noqa: E402
from analysis.records import (cell, load, machine, machine_dir, machine_label, no_answer_note, on,  # noqa: E402
                              paper_table, plots_dir, reference, summarise, writing)

MG = "MG-PCG "


def on_gpu(df):
    """The columns whose records say they ran on a GPU (backend_info.gpu: the device the program found)."""
    if df.empty or "backend_info.gpu" not in df:
        return []
    return sorted(set(df.loc[df["backend_info.gpu"].notna(), "column"]))


def column(row):
    """The Table 4.1 column a record belongs to: p<ranks> for MPI, the backend name otherwise; "MG-PCG " before
    it for --precond mg (records written before the option have no params.precond: plain CG)."""
    c = f"p{int(row['params.ranks'])}" if row["params.backend"] == "mpi" else row["params.backend"]
    return MG + c if row.get("params.precond") == "mg" else c


def column_order(columns):
    """Plain CG first (p1, p2, ... then openmp, serial and the other backends by name), then the same for MG-PCG."""
    def key(c):
        mg, base = c.startswith(MG), c[len(MG):] if c.startswith(MG) else c
        if base.startswith("p") and base[1:].isdigit():
            return (mg, 0, int(base[1:]), base)
        return (mg, 1, ("openmp", "serial").index(base) if base in ("openmp", "serial") else 2, base)
    return sorted(columns, key=key)


def method_note(wide, paper):
    """What the method changes against what the hardware changes: MG-PCG at the largest N it ran, against the
    report's 16 cores and K20 (cuBLAS 1) at that N, and our plain CG there."""
    mg = [c for c in wide.columns if c.startswith(MG)]
    if not mg:
        return None
    n = max(i for i in wide.index if wide.loc[i, mg].notna().any())
    best = wide.loc[n, mg].idxmin()
    text = f"MG-PCG at N = {n}: {wide.loc[n, best]:.3g} s ({best[len(MG):]})"
    if n in paper.index:
        text += (f", against the report's plain CG {paper.loc[n, 'p16']:.4g} s on 16 cores and "
                 f"{paper.loc[n, 'cublas1']:.4g} s on a K20 ({paper.loc[n, 'p16'] / wide.loc[n, best]:.0f}x and "
                 f"{paper.loc[n, 'cublas1'] / wide.loc[n, best]:.0f}x)")
    plain = [c for c in wide.columns if not c.startswith(MG) and pd.notna(wide.loc[n, c])]
    if plain:
        fast = wide.loc[n, plain].idxmin()
        text += (f"; our plain CG there: {wide.loc[n, fast]:.3g} s ({fast}, "
                 f"{wide.loc[n, fast] / wide.loc[n, best]:.2g}x MG-PCG's time)")
    return text + "."


def ours(preset):
    df = load("table41", preset)
    if df.empty:
        return df, df
    note = no_answer_note(df)
    df = df[(df["result.status"] == "converged") & (df["exit_status"] == 0)].copy()
    df.attrs["no_answer"] = note
    df["column"] = df.apply(column, axis=1)
    df["time_s"] = df["times_s.solve"] + df["times_s.setup"]
    return df, summarise(df, ["params.n", "column"], "time_s").rename(columns={"params.n": "n"})


PAPER_COLUMNS = ("p1", "p2", "p4", "p8", "p16", "cublas1", "cublas2")


def write_table(preset):
    return {"table41": emit("table41", preset, build, "N"), "table41_mg": emit("table41_mg", preset, build_mg, "N")}


def _cells(s, columns):
    """(wide frame of cells, wide frame of medians) over N for these columns of summary s."""
    sel = s[s["column"].isin(columns)]
    cells = {(r.n, r.column): cell(r._asdict()) for r in sel.itertuples()}
    meds = {(r.n, r.column): r.median for r in sel.itertuples()}
    return cells, meds


def not_run(column, gpu, cores):
    """Why a column of the report has no number of ours here: the report ran it on its K20 and this machine has no GPU
    (its machine.json), or it has more ranks than this machine has cores."""
    if settings.report_suffix(column) == " (K20)" and not gpu:
        return "not run (no GPU)"
    if column.startswith("p") and column[1:].isdigit() and cores and int(column[1:]) > cores:
        return f"not run (p > {cores} cores)"
    return "not run"


def build(preset):
    """Table 4.1 with every column of the report (p = 1 to 16, cuBLAS 1 and 2) at every N of ours or the report's;
    ours beside each column this machine ran; our columns the report has not (openmp, serial) after."""
    df, s = ours(preset)
    if s.empty:
        return None
    plain_s = s[~s["column"].str.startswith(MG)]
    plain = df[~df["column"].str.startswith(MG)]
    if plain_s.empty:
        return None
    paper = paper_table("table41").set_index("n")
    cores = int(plain["provenance.cpus_online"].max()) if "provenance.cpus_online" in plain else None
    cells, meds = _cells(plain_s, set(plain_s["column"]))
    gpu = (machine_label.read_owner(machine_dir()) or {}).get("gpu")  # machine.json, written by the runner
    extra = [c for c in column_order(set(plain_s["column"])) if c not in PAPER_COLUMNS]
    rows = []
    for n in sorted(set(plain_s["n"]) | set(paper.index)):
        row = {"N": n}
        for c in PAPER_COLUMNS:
            ran = (n, c) in cells
            row[f"ours {c}{settings.report_suffix(c)}"] = cells[(n, c)] if ran else (
                not_run(c, gpu, cores) if c not in set(plain_s["column"]) else "—")
            row[f"report {c}{settings.report_suffix(c)}"] = paper.loc[n, c] if n in paper.index else float("nan")
            if c in set(plain_s["column"]):
                row[f"ratio {c}"] = meds[(n, c)] / paper.loc[n, c] if ran and n in paper.index else float("nan")
        for c in extra:
            row[f"ours {c}{settings.threads_of(plain, c)}"] = cells.get((n, c), "—")
        rows.append(row)
    built = (f"Table 4.1 ({preset}): Poisson CG to 1e-6, run time in s (setup + solve)", pd.DataFrame(rows),
             [settings.line(plain, preset, "ranks as in each header; cuBLAS 1 and 2 on one NVIDIA K20 in the report"),
              threads_note(plain), no_gpu_note("table41", preset),
              "MG-PCG, a different algorithm, is in its own table below, never in this one."], s)
    if writing():
        figure(preset, plain_s, paper, plain)
    return built


def build_mg(preset):
    """CG preconditioned by one multigrid V-cycle (beyond the report): its own table, beside our plain CG."""
    df, s = ours(preset)
    mg = s[s["column"].str.startswith(MG)] if not s.empty else s
    if mg.empty:
        return None
    cells, _ = _cells(mg, set(mg["column"]))
    rows = [{"N": n, **{f"ours {c}": cells.get((n, c), "—") for c in column_order(set(mg["column"]))}}
            for n in sorted(set(mg["n"]))]
    wide = s.pivot(index="n", columns="column", values="median")
    paper = paper_table("table41").set_index("n")
    mgdf = df[df["column"].str.startswith(MG)]
    return (f"MG-PCG ({preset}): Poisson CG preconditioned by one multigrid V-cycle, to 1e-6, run time in s "
            "(beyond the report)", pd.DataFrame(rows),
            [settings.line(mgdf, preset, "a different algorithm from the report's plain CG"), threads_note(mgdf),
             method_note(wide, paper)], mg)


def figure(preset, s, paper, runs):
    """Figure 4.1: ours (median, 95% interval as error bars) beside the report's columns, a tick at every decade."""
    from matplotlib.ticker import LogLocator
    fig, ax = plt.subplots(figsize=(6.5, 4.8))
    markers = iter("osD^v<>ph*")
    for i, c in enumerate(column_order(set(s["column"]))):
        g = s[s["column"] == c].sort_values("n")
        lo = (g["median"] - g["ci_low"]).fillna(0).clip(lower=0)
        hi = (g["ci_high"] - g["median"]).fillna(0).clip(lower=0)
        ax.errorbar(g["n"] * (1 + 0.03 * i), g["median"], yerr=[lo, hi], fmt=next(markers, "o") + "-", capsize=3,
                    markersize=7 - i, label=f"ours {c}{settings.threads_of(runs, c)}")
    for c in PAPER_COLUMNS:
        ax.plot(paper.index, paper[c], "x--", alpha=0.7, label=f"report {c}{settings.report_suffix(c)}")
    ref = reference()
    if ref and ref != machine():  # the reference machine's fastest plain column, for scale
        with on(ref):
            _, rs = ours(preset)
        rs = rs[~rs["column"].str.startswith(MG)] if not rs.empty else rs
        if not rs.empty:
            best = rs.groupby("n")["median"].min()
            ax.plot(best.index, best.values, "s:", color="grey", label=f"ref {ref} (fastest column)")
    ax.set_xscale("log", base=2)
    ax.set_yscale("log")
    ax.yaxis.set_major_locator(LogLocator(base=10, numticks=20))
    ax.set_xlabel("N (grid points per dimension)")
    ax.set_ylabel("run time (s): median, bars the 95% interval")
    ax.set_title(f"Figure 4.1: Poisson CG ({preset}) beside the report")
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    plots_dir().mkdir(parents=True, exist_ok=True)
    fig.savefig(plots_dir() / f"figure41_{preset}.png", dpi=120)
    plt.close(fig)
