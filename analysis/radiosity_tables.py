"""Tables 4.2-4.5 of the report from the radiosity records, beside the published numbers."""
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from analysis.escape import md, md_table  # noqa: E402
from analysis import consistency, protocol, settings  # noqa: E402
from analysis.records import (cell, load, machine, no_answer_note, on, paper_table, plots_dir, reference,  # noqa: E402
                              skipped, summarise, tables_dir, value, writing)


def run_time(df):
    """What the report times as a run: building the solver's data (and uploading F to a GPU) plus the iterations;
    not the scene or form-factor file loading, which the report did before its timer started."""
    t = df["times_s.setup"] + df["times_s.solve"]
    if "times_s.upload" in df.columns:
        t = t + df["times_s.upload"].fillna(0)
    return t


def solves(experiment, preset):
    """The solves of an experiment that are an answer (exit status 0); the others are named by threads_note. Every
    column comes from the experiment's own records: no table borrows another's (issue 50)."""
    df = load(experiment, preset)
    if df.empty:
        return df
    df = df[df["params.command"] == "solve"].copy()
    note = no_answer_note(df)
    df = df[df["exit_status"] == 0].copy()
    df["time_s"] = run_time(df)
    df["column"] = df.apply(column_of, axis=1)
    df.attrs["no_answer"] = note
    return df


def with_work(s, df, keys):
    """A summarise table with each group's iterations and time per iteration (the median of time / iterations), so
    that the codes can be compared on equal work (issue 50: Original runs the report's fixed steps, the others run to
    1e-6)."""
    w = df.assign(s_per_it=df["time_s"] / df["result.iterations"].where(df["result.iterations"] > 0))
    w = w.groupby(keys).agg(iterations=("result.iterations", "median"), s_per_it=("s_per_it", "median")).reset_index()
    return s.merge(w, on=keys, how="left")


def work_cell(row):
    """A timing cell with its run's work: "median [interval] n=runs; iterations it, time per iteration"."""
    text = cell(row)
    it, per = row.get("iterations", np.nan), row.get("s_per_it", np.nan)
    if text == "—" or not np.isfinite(it) or not np.isfinite(per):
        return text
    return f"{text}; {it:.0f} it, {per * 1e3:.3g} ms/it"


def column_of(r):
    """The report's column a solve belongs to: its CUDA columns are our `cuda` (AOS, own kernels) and `cublas`
    (SOA, one cublasSgemv per channel as the report did; `--fused` reads F once for the three channels)."""
    b = r["params.backend"]
    if b == "cublas":
        return "cuda_fused" if r.get("params.fused") is True else "cuda"
    return b


def no_gpu_note(experiment, preset):
    """What the runner skipped on this machine and why, one sentence per reason."""
    s = skipped(experiment, preset)
    if s.empty:
        return ""
    hosts = md(", ".join(sorted(set(map(str, s["host"])))))
    notes = []
    if (s["reason"] == "no GPU on this machine").any():
        notes.append(f"No GPU on this machine ({hosts}): the CUDA cases were not run, and no number stands in for them.")
    if s["reason"].astype(str).str.startswith("needs >= ").any():
        notes.append("Cases with more MPI ranks than this machine has cores were not run (such a run measures the "
                     "oversubscription, not the code; OVERSUBSCRIBE=1 runs them, recorded as oversubscribed).")
    if (s["reason"] == "no RRV scenes").any():
        notes.append("No RRV scenes on this machine: the cases of scenes 3 and 4 (RRV's room3.xml and room2.xml) were "
                     "not run (`make scenes` fetches them), and no number stands in for them.")
    return " ".join(notes)


def compare(ours, paper, key, columns):
    """One row per key value: ours (median), the report's, and ours/report for every column."""
    rows = []
    for k in sorted(set(paper[key]) | set(ours.get(key, pd.Series(dtype=float)))):
        row = {key: k}
        p = paper[paper[key] == k]
        for c in columns:
            o = ours[(ours[key] == k) & (ours["column"] == c)] if not ours.empty else ours
            mine = o["median"].iloc[0] if len(o) else np.nan
            theirs = p[c].iloc[0] if len(p) and c in p.columns else np.nan
            row[f"ours {c}"] = work_cell(o.iloc[0]) if len(o) else "—"
            row[f"report {c}"] = theirs
            row[f"ratio {c}"] = mine / theirs if np.isfinite(mine) and np.isfinite(theirs) else np.nan
        rows.append(row)
    return pd.DataFrame(rows)


def markdown(title, table, notes):
    body = md_table(table)
    return "\n".join([f"### {title}", "", body, "", *[n for n in notes if n]]) + "\n"


def beside(mine, ref, key, label):
    """This machine's table with the reference machine's "ours" numbers beside each of its own: for every column
    "ours X", a column "<label> X" and "ours/<label> X" (the ratios to the report stay this machine's)."""
    cols = []
    r = ref.set_index(key)
    theirs = {settings.base(c): c for c in r.columns}
    for c in mine.columns:
        cols.append(c)
        if c.startswith("ours "):
            what = settings.base(c)[len("ours "):]
            rc = theirs.get(settings.base(c))
            mine[f"{label} {what}"] = mine[key].map(r[rc]) if rc else np.nan
            mine[f"ours/{label} {what}"] = mine[c].map(value) / mine[f"{label} {what}"].map(value)
            cols += [f"{label} {what}", f"ours/{label} {what}"]
    return mine[cols]


def emit(name, preset, build, key):
    """Builds a table on the current machine (build(preset) -> (title, table, notes, detail) or None), puts the
    reference machine's numbers beside it when the current machine is another, and writes it: the csv holds the
    detail (this machine's summaries), the md the table as the report shows it."""
    got = build(preset)
    if got is None:
        return None
    title, table, notes, detail = got
    ref = reference()
    if ref and ref != machine():
        with on(ref):
            theirs = build(preset)
        title += f", on {md(machine())} beside the reference machine {md(ref)}"
        if theirs is None:
            notes = [*notes, f"The reference machine {md(ref)} has no records of this table."]
        else:
            table = beside(table.copy(), theirs[1], key, "ref")
            notes = [*notes, f"ours: this machine ({md(machine())}); ref: the reference machine {md(ref)} "
                             f"(results/{md(ref)}/), "
                             "with its own records; ours/ref: this machine's time over the reference's."]
    return write(name, preset, title, table, notes, detail)


def write(name, preset, title, table, notes, detail=None):
    text = markdown(title, table, notes)
    if writing():
        tables_dir().mkdir(parents=True, exist_ok=True)
        (detail if detail is not None else table).to_csv(tables_dir() / f"{name}_{preset}.csv", index=False)
        (tables_dir() / f"{name}_{preset}.md").write_text(text)
    return text


def table42(preset):
    return emit("table42", preset, build_table42, "scene")


def build_table42(preset):
    df = solves("table42", preset)
    if df.empty:
        return None
    t = with_work(summarise(df, ["scene_id", "params.patches", "params.method"], "time_s"), df,
                  ["scene_id", "params.method"])
    for (sid, m), g in df.groupby(["scene_id", "params.method"]):
        consistency.quote(f"scene {int(sid)}: {'Jacobi' if m == 'jacobi' else m} solve to 1e-6, run time (setup + "
                          "solve, s)", f"Table 4.2 ({preset}), scene {int(sid)}, ours {m} s", g["time_s"], g)
    paper = paper_table("table42")
    rows = []
    for s in sorted(set(t["scene_id"]) | set(paper["scene"])):
        row = {"scene": s}
        mine = t[t["scene_id"] == s]
        row["patches"] = int(mine["params.patches"].iloc[0] if len(mine) else paper.loc[paper.scene == s, "patches"].iloc[0])
        p = paper[paper["scene"] == s]
        for m in ("jacobi", "bicgstab"):
            o = mine[mine["params.method"] == m]
            row[f"ours {m} iter"] = o["iterations"].iloc[0] if len(o) else np.nan
            row[f"report {m} iter"] = p[f"{m}_iter"].iloc[0] if len(p) else np.nan
            row[f"ours {m} s"] = work_cell(o.iloc[0]) if len(o) else "—"
            row[f"report {m} s"] = p[f"{m}_s"].iloc[0] if len(p) else np.nan
        rows.append(row)
    th = settings.threads_of(df.assign(column="openmp"), "openmp")
    table = pd.DataFrame(rows).rename(columns=lambda c: c + th if c.startswith("ours ") and c.endswith(" s") else
                                      c + " (16 threads)" if c.startswith("report ") and c.endswith(" s") else c)
    return (f"Table 4.2 ({preset}): OpenMP Jacobi vs. BiCG-STAB to 1e-6 (run time in s)", table,
            [settings.line(df, preset), threads_note(df), no_gpu_note("table42", preset)], t)


def threads_note(df):
    th = sorted(set(df["params.threads"].dropna().astype(int)))
    hosts = sorted(set(df["provenance.host"]))
    note = df.attrs.get("no_answer", "")
    parts = [f"Ours: median [95% interval of the median] n=runs, on {md(', '.join(map(str, hosts)))} with "
             f"{', '.join(map(str, th))} OpenMP thread(s); capped: the interval is not within +-5% of the median (or "
             "the runner stopped at its cap).", storage_note(df), note,
             protocol.note(df["file"] if "file" in df else [])]
    return " ".join(p for p in parts if p)


def storage_note(df):
    """Which storage of F the runs read (issue 17): the case lists pin the report's dense float32, so that a table
    compares the work the report did. Nothing for records without F (Poisson's)."""
    if df.empty or "params.storage" not in df:
        return ""
    values = df["params.ff_precision"] if "params.ff_precision" in df else pd.Series("float32", index=df.index)
    used = (df["params.storage"].fillna("dense") + " " + values.fillna("float32")).value_counts()
    if list(used.index) == ["dense float32"]:
        return ("F as the report stored it, dense float32, in every run (the case lists pin `--storage dense`; "
                "the default `--storage auto` would read a sparse storage where F has many zeros: "
                "docs/design-notes.md, \"Sparse form factors\").")
    return "F read as " + ", ".join(f"{k} ({v} runs)" for k, v in used.items()) + "."


def aos_soa(name, preset, layout, columns, extra=()):
    return emit(name, preset, lambda p: build_aos_soa(name, p, layout, columns, extra), "scene")


def build_aos_soa(name, preset, layout, columns, extra=()):
    df = solves(name, preset)  # Table 4.4's Original column (the report repeats 4.3's) is its own runs too
    if df.empty:
        return None
    s = with_work(summarise(df, ["scene_id", "column"], "time_s"), df, ["scene_id", "column"])
    s = s.rename(columns={"scene_id": "scene"})
    for sid, g in df[df["column"] == "openmp"].groupby("scene_id"):
        consistency.quote(f"scene {int(sid)}: Jacobi solve to 1e-6, run time (setup + solve, s)",
                          f"Table {name[-2]}.{name[-1]} ({preset}), scene {int(sid)}, ours openmp", g["time_s"], g)
    table = compare(s, paper_table(name), "scene", columns)
    for c in extra:
        o = s[s["column"] == c].set_index("scene")
        table[f"ours {c}"] = table["scene"].map(lambda k: work_cell(o.loc[k]) if k in o.index else "—")
    table = table.rename(columns=lambda c: c + settings.threads_of(df, c[len("ours "):]) if c.startswith("ours ") else
                         c + settings.report_suffix(c[len("report "):]) if c.startswith("report ") else c)
    title = f"Table {name[-2]}.{name[-1]} ({preset}): {layout} Jacobi to 1e-6, run time in s"
    return title, table, [settings.line(df, preset), threads_note(df), no_gpu_note(name, preset),
                          "Original: RRV's loop for the report's Jacobi iterations of that scene; the others run to "
                          "1e-6. Each cell: the run time, then its iterations (it) and the time per iteration "
                          "(ms/it), the median over its runs: the codes compared on equal work."], s


def table45(preset):
    return emit("table45", preset, build_table45, "distribution")


def build_table45(preset):
    df = solves("table45", preset)
    paper = paper_table("table45")
    note = no_gpu_note("table45", preset)
    s = summarise(df, ["params.distribution"], "time_s") if not df.empty else pd.DataFrame()
    table = paper.rename(columns={"runtime_s": "report s"})
    by = s.set_index("params.distribution") if len(s) else None
    table["ours s"] = table["distribution"].map(lambda d: cell(by.loc[d]) if by is not None and d in by.index else "—")
    table["ratio"] = table["ours s"].map(value) / table["report s"]
    title = f"Table 4.5 ({preset}): hybrid CPU/GPU Jacobi, run time in s"
    what = "the report's: scene 4 (RRV's room2.xml) on 16 cores and a K20"
    note = " ".join(n for n in (settings.line(df, preset, what) if len(df) else settings.planned("table45", preset, what),
                                note) if n)
    if not writing():
        return title, table, [note], s if len(s) else table
    plots_dir().mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(5.5, 3.8))
    ax.plot(paper["distribution"], paper["runtime_s"], "x--", label="report (scene 4, K20 + 16 cores)")
    if len(s):
        ax.errorbar(s["params.distribution"], s["median"], yerr=[s["median"] - s["ci_low"].fillna(s["median"]),
                    s["ci_high"].fillna(s["median"]) - s["median"]], fmt="o-", capsize=3,
                    label="ours (median, 95% interval)")
    else:
        ax.text(0.5, 0.5, "ours: no GPU on this machine", transform=ax.transAxes, ha="center")
    ax.set_xlabel("distribution factor d (share of rows on the GPU)")
    ax.set_ylabel("run time (s)")
    ax.set_title(f"Table 4.5: hybrid CPU/GPU Jacobi ({preset})")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(plots_dir() / f"table45_{preset}.png", dpi=120)
    plt.close(fig)
    return title, table, [note], s if len(s) else table


def write_all(preset):
    return {
        "table42": table42(preset),
        "table43": aos_soa("table43", preset, "AOS", ["original", "serial", "cuda", "openmp"]),
        "table44": aos_soa("table44", preset, "SOA", ["original", "serial", "cuda", "openmp"], extra=["cuda_fused"]),
        "table45": table45(preset),
    }
