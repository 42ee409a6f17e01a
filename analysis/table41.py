"""Table 4.1 and Figure 4.1: Poisson CG run time against N, per MPI process count and per CUDA variant, beside
the report's published numbers; and beyond the report, CG preconditioned by one multigrid V-cycle (bin/poisson
--precond mg, issue 19) in the columns "MG-PCG ..." and their curves."""
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from analysis.radiosity_tables import emit, no_gpu_note, threads_note  # noqa: E402
from analysis.records import (load, machine, no_answer_note, on, paper_table, plots_dir, reference, summarise,  # noqa: E402
                              writing)

GPU = ("cublas1", "cublas2", "cuda")


MG = "MG-PCG "


def column(row):
    """The Table 4.1 column a record belongs to: p<ranks> for MPI, the backend name otherwise; "MG-PCG " before
    it for --precond mg (records written before the option have no params.precond: plain CG)."""
    c = f"p{int(row['params.ranks'])}" if row["params.backend"] == "mpi" else row["params.backend"]
    return MG + c if row.get("params.precond") == "mg" else c


def column_order(columns):
    """Plain CG first (p1, p2, ... then openmp, serial and the GPU variants), then the same for MG-PCG."""
    def key(c):
        mg, base = c.startswith(MG), c[len(MG):] if c.startswith(MG) else c
        if base.startswith("p") and base[1:].isdigit():
            return (mg, 0, int(base[1:]), base)
        return (mg, 1, ("openmp", "serial", *GPU).index(base) if base in ("openmp", "serial", *GPU) else 99, base)
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


def write_table(preset):
    return emit("table41", preset, build, "N")


def build(preset):
    df, s = ours(preset)
    if s.empty:
        return None
    paper = paper_table("table41").set_index("n")
    wide = s.pivot(index="n", columns="column", values="median")
    cols = column_order(wide.columns)
    rows = []
    for n in wide.index:
        row = {"N": n}
        for c in cols:
            row[f"ours {c}"] = wide.loc[n, c]
            if n in paper.index and c in paper.columns:
                row[f"report {c}"] = paper.loc[n, c]
                row[f"ratio {c}"] = wide.loc[n, c] / paper.loc[n, c]
        rows.append(row)
    built = (f"Table 4.1 ({preset}): Poisson CG to 1e-6, run time in s (setup + solve)", pd.DataFrame(rows),
             [threads_note(df), no_gpu_note("table41", preset), method_note(wide, paper)], s)
    if not writing():
        return built

    fig, ax = plt.subplots(figsize=(6, 4.5))
    for c in cols:
        ax.loglog(wide.index, wide[c], "s-" if c.startswith(MG) else "o-", label=f"ours {c}")
    for c in ("p1", "p16", "cublas1", "cublas2"):
        ax.loglog(paper.index, paper[c], "x--", alpha=0.6, label=f"report {c}")
    ref = reference()
    if ref and ref != machine():  # the reference machine's fastest column, for scale
        with on(ref):
            _, rs = ours(preset)
        if not rs.empty:
            best = rs.groupby("n")["median"].min()
            ax.loglog(best.index, best.values, "s:", color="grey", label=f"ref {ref} (fastest column)")
    ax.set_xlabel("N (grid points per dimension)")
    ax.set_ylabel("run time (s)")
    ax.set_title(f"Figure 4.1: Poisson CG ({preset}) vs. the report")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    plots_dir().mkdir(parents=True, exist_ok=True)
    fig.savefig(plots_dir() / f"figure41_{preset}.png", dpi=120)
    plt.close(fig)
    return built
