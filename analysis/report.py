"""The reproduced report of one machine: report/<machine>/REPORT-<preset>.md with the machine's provenance, every
table and figure beside the report's numbers (and the reference machine's, for any other machine), and for each
claim of the report whether this machine's records confirm it, refute it, or cannot say, the reference machine's
verdict beside it."""
import os

import pandas as pd

from analysis.escape import md
from analysis import accuracy, mpi_radiosity, radiosity_tables, table41, table42_audit
from analysis.records import load, machine, machine_dir, on, plots_dir, reference, report_dir, skipped, tables_dir

EXPERIMENTS = ("table41", "formfactors", "table42", "table43", "table44", "table45", "figure42", "mpi-formfactors",
               "mpi-radiosity", "mpi-large")


def provenance(preset):
    frames = [f.dropna(axis=1, how="all") for f in (load(e, preset) for e in EXPERIMENTS) if not f.empty]
    df = pd.concat(frames, ignore_index=True) if frames else None
    if df is None:
        return ["No records yet: run `make reproduce PRESET=%s`." % preset], 0
    lines = []
    for col, what in (("provenance.host", "host"), ("provenance.cpu_model", "CPU"), ("provenance.cpus_online", "CPUs"),
                      ("provenance.compiler", "compiler"), ("provenance.git_commit", "git commit"),
                      ("backend_info.gpu", "GPU"), ("backend_info.mpi_library", "MPI")):
        if col in df.columns:
            vals = sorted({str(v) for v in df[col].dropna()})
            lines.append(f"- {what}: {md(', '.join(vals)) if vals else 'none'}")
    if "backend_info.gpu" not in df.columns:
        lines.append("- GPU: none used (no GPU on this machine)")
    if "provenance.loadavg_1min" in df.columns:
        busy = (df["provenance.loadavg_1min"] > df["provenance.cpus_online"] + 0.5).sum()
        lines.append(f"- machine load: {busy} of {len(df)} records were taken while the 1-minute load average exceeded "
                     "the core count (other work was running: their times are upper bounds)")
    dirty = df["provenance.git_dirty"].astype(bool).sum() if "provenance.git_dirty" in df.columns else 0
    lines.append(f"- records: {len(df)} ({dirty} from a working tree with uncommitted changes), "
                 f"UTC {df['provenance.utc'].min()} to {df['provenance.utc'].max()}")
    return lines, len(df)


def medians(experiment, preset, keys):
    df = radiosity_tables.solves(experiment, preset)
    if df.empty:
        return df
    g = df.groupby(keys).agg(time_s=("time_s", "median"), iterations=("result.iterations", "median"))
    return g.reset_index()


def claim_bicgstab(preset):
    m = medians("table42", preset, ["scene_id", "params.method"])
    if m.empty:
        return "cannot say", "no Table 4.2 records"
    w = m.pivot(index="scene_id", columns="params.method")
    fewer = (w["iterations"]["bicgstab"] < w["iterations"]["jacobi"])
    slower = (w["time_s"]["bicgstab"] > w["time_s"]["jacobi"])
    nums = "; ".join(f"scene {s}: {w['iterations']['jacobi'][s]:.0f} vs {w['iterations']['bicgstab'][s]:.0f} iterations, "
                     f"{w['time_s']['jacobi'][s]:.4g} s vs {w['time_s']['bicgstab'][s]:.4g} s" for s in w.index)
    if fewer.all() and slower.all():
        return "confirmed", nums
    if fewer.all() and not slower.any():
        return "refuted: BiCG-STAB needs fewer iterations and is also faster", nums
    return "partly", nums


def claim_gpu(preset, experiment, what):
    df = radiosity_tables.solves(experiment, preset) if experiment != "table41" else load("table41", preset)
    gpu = df[df["params.backend"].isin(["cuda", "cublas", "cublas1", "cublas2", "hybrid"])] if not df.empty else df
    if gpu.empty:
        return "cannot say", f"no GPU on this machine: {what} not measured"
    return None, ""


def claim_aos_openmp(preset):
    verdict, why = claim_gpu(preset, "table43", "the CUDA AOS column")
    m = medians("table43", preset, ["scene_id", "params.backend"])
    if m.empty:
        return "cannot say", "no Table 4.3 records"
    w = m.pivot(index="scene_id", columns="params.backend", values="time_s")
    cpu = [c for c in ("original", "serial", "openmp") if c in w.columns]
    best = w[cpu].idxmin(axis=1)
    nums = "; ".join(f"scene {s}: fastest CPU column {best[s]} ({w.loc[s, best[s]]:.4g} s)" for s in w.index)
    if verdict:
        return verdict, f"{why}. Among the CPU columns: {nums}"
    allc = [c for c in ("original", "serial", "openmp", "cuda") if c in w.columns]
    best = w[allc].idxmin(axis=1)
    ok = all(best[s] == ("cuda" if s == min(w.index) else "openmp") for s in w.index)
    return ("confirmed" if ok else "refuted"), "; ".join(f"scene {s}: fastest {best[s]}" for s in w.index)


def claim_soa(preset):
    verdict, why = claim_gpu(preset, "table44", "the cuBLAS SOA column")
    if verdict:
        return verdict, why
    m = medians("table44", preset, ["scene_id", "column"])
    w = m.pivot(index="scene_id", columns="column", values="time_s")
    large = max(w.index)
    ok = w.loc[large, "cuda"] < w.loc[large, "openmp"]
    return ("confirmed" if ok else "refuted"), f"scene {large}: cuBLAS {w.loc[large, 'cuda']:.4g} s, openmp {w.loc[large, 'openmp']:.4g} s"


def claim_hybrid(preset):
    verdict, why = claim_gpu(preset, "table45", "the hybrid sweep")
    if verdict:
        return verdict, why
    df = radiosity_tables.solves("table45", preset)
    t = df.groupby("params.distribution")["time_s"].median()
    best = t.idxmin()
    ok = 0 < best < 1
    return ("confirmed" if ok and abs(best - 0.1) < 0.15 else "refuted"), f"fastest at d = {best:.1f} ({t[best]:.4g} s); d = 0: {t.get(0.0, float('nan')):.4g} s, d = 1: {t.get(1.0, float('nan')):.4g} s"


def claim_poisson_gpu(preset):
    verdict, why = claim_gpu(preset, "table41", "the CUDA Poisson runs")
    if verdict:
        return verdict, why
    df, s = table41.ours(preset)
    n = s["n"].max()
    at = s[s["n"] == n].set_index("column")["median"]
    gpu = at[[c for c in at.index if c in table41.GPU]].min()
    cpu = at[[c for c in at.index if c not in table41.GPU]].min()
    return ("confirmed" if gpu < cpu else "refuted"), f"N = {n}: best GPU {gpu:.4g} s, best CPU {cpu:.4g} s"


CLAIMS = [
    ("BiCG-STAB needs fewer iterations than Jacobi but more time (Table 4.2)", claim_bicgstab),
    ("AOS with OpenMP is the fastest, except on the smallest scene where CUDA wins (Table 4.3)", claim_aos_openmp),
    ("SOA with cuBLAS beats SOA with OpenMP on large scenes (Table 4.4)", claim_soa),
    ("The hybrid is fastest near d = 0.1 but does not beat the single devices (Table 4.5)", claim_hybrid),
    ("The GPU wins for large Poisson meshes (Table 4.1)", claim_poisson_gpu),
]


def include(name, preset):
    f = tables_dir() / f"{name}_{preset}.md"
    return f.read_text() if f.exists() else f"### {name}\n\nNo records for this preset yet.\n"


def image(name, preset, alt):
    f = plots_dir() / f"{name}_{preset}.png"
    return f"![{alt}]({os.path.relpath(f, report_dir())})\n" if f.exists() else f"({alt}: no records yet)\n"


def not_run(preset):
    """What the runner skipped on this machine, per experiment and reason (no GPU, no RRV scenes)."""
    rows = []
    for f in sorted(machine_dir().glob(f"*/{preset}.skipped")):
        s = skipped(f.parent.name, preset)
        for reason, g in (s.groupby("reason") if len(s) else ()):
            rows.append(f"| {md(f.parent.name)} | {len(g)} | {md(reason)} |")
    if not rows:
        return ["Every case of this preset ran on this machine."]
    out = ["| experiment | cases skipped | why |", "|---|---|---|", *rows, ""]
    if any("no RRV scenes" in r for r in rows):
        out.append("The experiments with \"no RRV scenes\" lack scenes 3 and 4 (RRV's room3.xml and room2.xml): "
                   "`make scenes` fetches them, then `make resume` runs what is missing.")
    return out


def claims(preset):
    """The claims table: this machine's verdicts, and for any other machine than the reference the reference's."""
    ref = reference()
    other = ref if ref and ref != machine() else None
    head = "| claim | our data | the numbers that decide it |" + (f" reference {md(other)} |" if other else "")
    rows = [head, "|---|---|---|" + ("---|" if other else "")]
    for text, fn in CLAIMS:
        verdict, why = fn(preset)
        row = f"| {text} | {verdict} | {why} |"
        if other:
            with on(other):
                row += f" {fn(preset)[0]} |"
        rows.append(row)
    return rows


def write(preset):
    prov, n = provenance(preset)
    ref = reference()
    if ref == machine():
        whose = f"This is the reference machine ({md(ref)}), which every other machine's report is set beside."
    elif ref:
        whose = (f"Each table sets this machine's numbers (ours) beside the reference machine's ({md(ref)}, "
                 f"results/{md(ref)}/) and the report's; each claim is decided on this machine's records, the "
                 "reference's verdict beside it.")
    else:
        whose = "There is no reference machine's record folder here to set these numbers beside."
    out = [f"# Reproduced report ({md(preset)} preset) on {md(machine())}", "",
           "The report: *Real Time Global Illumination Solutions to the Radiosity Algorithm using Hybrid CPU/GPU "
           f"Nodes* (UMBC HPCF-2014-15). Every number below comes from this machine's records in results/{md(machine())}/ "
           f"(made by `make reproduce PRESET={preset}`, tables by `make plots`); the report's numbers from "
           "`results/paper/`. Ratios are ours / report's. Our machine is not the report's (one maya node: 2 × 8-core "
           "Intel E5-2650v2 and an NVIDIA K20), so ratios of times compare machines as much as codes. " + whose, "",
           "## Machine and provenance", "", *prov, "",
           "## Cases not run on this machine", "", *not_run(preset), "",
           "## Claims of the report", "", *claims(preset)]
    out += ["", "## Poisson CG", "", include("table41", preset), image("figure41", preset, "Figure 4.1"),
            "## Radiosity", "", include("table42", preset), include("table43", preset), include("table44", preset),
            include("table45", preset), image("table45", preset, "Table 4.5 as a curve"),
            *table42_audit.report_section(preset, include, image),
            "### Figure 4.2", "", image("figure42", preset, "Figure 4.2"), "",
            *accuracy.report_section(preset, include, image), "",
            *mpi_radiosity.report_section(preset, include, image),
            *__import__("analysis.relight", fromlist=["report_section"]).report_section(preset, include, image),
            "## Performance: the bandwidth limit and the peers (`make bench`)", "", include("bench", preset)]
    path = report_dir() / f"REPORT-{preset}.md"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(out) + "\n")
    return path
