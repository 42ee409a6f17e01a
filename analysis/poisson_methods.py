"""Table 4.1's question answered to the end (issue 37, item 4): the time to solution of the Poisson problem per
method at every N, CG, MG-PCG, FMG and the direct DST solver, each our fastest configuration with its 95% interval and
n, beside the report's p = 1, p = 16 and K20 (cuBLAS 1) columns.

Sources: the table41 records (bin/poisson: plain CG, --precond mg, --method fmg) and the bench-mg records of `make
bench` (bin/poisson's MG-PCG and FMG, and bench/dst_poisson.py's DST-I solve); a record's method is its params.method
and params.precond. Time to solution is setup + solve for every method (Table 4.1's run time), so the columns are
comparable; PETSc's rows of the bench are the bench table's, not this one's."""
import numpy as np
import pandas as pd

from analysis import settings
from analysis.records import cell, load, no_answer_note, paper_table, summarise

METHODS = ("CG", "MG-PCG", "FMG", "DST")
PAPER = (("p1", "report CG p1 (1 rank)"), ("p16", "report CG p16 (16 ranks)"), ("cublas1", "report CG K20 (cuBLAS 1)"))
SOURCES = (("table41", "Table 4.1's runs"), ("bench-mg", "make bench"))


def method_of(row):
    """CG, MG-PCG, FMG or DST from a record's params (records older than --method have none: CG, or MG-PCG by
    --precond); None for what is not one of ours or the DST solver (PETSc's peers)."""
    method = row.get("params.method")
    method = method if isinstance(method, str) else "cg"
    precond = row.get("params.precond")
    if method == "dst" or str(row.get("params.peer", "")).startswith("dst"):
        return "DST"
    if row.get("app") == "peer":
        return None
    if method == "fmg":
        return "FMG"
    return "MG-PCG" if precond == "mg" else "CG"


def configuration(row):
    """Where a record ran, as the cell names it: p<ranks> for MPI, else the backend (or the DST's FFT library), and its
    threads."""
    if str(row.get("params.peer", "")).startswith("dst"):
        return f"{row['params.peer']}, {int(row['params.threads'])} thr"
    th = row.get("params.threads")
    th = f", {int(th)} thr" if isinstance(th, (int, float, np.integer, np.floating)) and np.isfinite(th) else ""
    if row.get("params.backend") == "mpi":
        return f"p{int(row['params.ranks'])}{th}"
    return f"{row.get('params.backend')}{th}"


def runs(preset):
    """Every answered run of either source, with its method, configuration, source and time to solution."""
    frames, notes = [], []
    for exp, source in SOURCES:
        df = load(exp, preset)
        if df.empty:
            continue
        notes.append(no_answer_note(df))
        df = df[(df["exit_status"] == 0) & (df["result.status"] == "converged")].copy()
        if df.empty:
            continue
        df["method"] = df.apply(method_of, axis=1)
        df = df[df["method"].notna()].copy()
        df["config"] = df.apply(configuration, axis=1)
        df["source"] = source
        setup = df["times_s.setup"].fillna(0) if "times_s.setup" in df else 0
        df["time_s"] = df["times_s.solve"] + setup
        frames.append(df)
    out = pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()
    out.attrs["no_answer"] = " ".join(n for n in notes if n)
    return out


def fastest(s):
    """Per (n, method): the summary row of the configuration with the smallest median."""
    s = s.sort_values(["n", "method", "median"])
    return s.drop_duplicates(["n", "method"], keep="first")


def build(preset):
    """(title, table, notes, detail) or None: one row per N of ours or the report's; per method our fastest
    configuration's median [interval] n and where it ran, then the report's three columns."""
    df = runs(preset)
    if df.empty:
        return None
    s = summarise(df, ["params.n", "method", "config", "source"], "time_s").rename(columns={"params.n": "n"})
    best = fastest(s)
    paper = paper_table("table41").set_index("n")
    rows = []
    for n in sorted(set(int(v) for v in s["n"]) | set(int(v) for v in paper.index)):
        row = {"N": n}
        for m in METHODS:
            b = best[(best["n"] == n) & (best["method"] == m)]
            row[f"ours {m}"] = (f"{cell(b.iloc[0])} ({b.iloc[0]['config']}; {b.iloc[0]['source']})" if len(b)
                                else "—")
        for c, head in PAPER:
            row[head] = paper.loc[n, c] if n in paper.index else np.nan
        rows.append(row)
    missing = [m for m in METHODS if not (s["method"] == m).any()]
    notes = [settings.line(df, preset, "time to solution: setup + solve (Table 4.1's run time) for every method, "
                                       "the DST's too (making b and the plan, then its two transforms)"),
             "Ours: the fastest configuration of each method at that N, median [95% interval of the median] n=runs "
             "(capped: the interval is not within +-5% of the median), where it ran (p<ranks>, or the backend; "
             "thr: OpenMP threads) and from which records. The report's: plain CG only, its published times.",
             (f"No records of {', '.join(missing)} for this preset: "
              + "; ".join(WHY[m] for m in missing) + ".") if missing else "",
             df.attrs.get("no_answer", "")]
    return (f"Time to solution per method ({preset}): Poisson to 1e-6, s", pd.DataFrame(rows), notes,
            s.sort_values(["n", "method", "median"]))


WHY = {"CG": "CG runs in the table41 case list (`make reproduce`)",
       "MG-PCG": "MG-PCG runs in the table41 case list and in `make bench`",
       "FMG": "FMG (`bin/poisson --method fmg`) runs in `make bench` (bench-mg)",
       "DST": "the DST solver (bench/dst_poisson.py) runs in `make bench` (bench-mg)"}


def write_table(preset):
    from analysis.radiosity_tables import emit
    return {"poisson_methods": emit("poisson_methods", preset, build, "N")}
