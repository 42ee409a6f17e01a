"""The reproduced report of one machine: report/<machine>/REPORT-<preset>.md with the machine's provenance, every
table and figure beside the report's numbers (and the reference machine's, for any other machine), and for each
claim of the report whether this machine's records confirm it, refute it, or cannot say, the reference machine's
verdict beside it."""
import os

import pandas as pd

from analysis.escape import md
from analysis import accuracy, mpi_radiosity, radiosity_tables, table41, table42_audit
from analysis import claims as claims_mod
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


RULE = ("Each claim is decided part by part on this machine's records by one rule: the bootstrap 95% interval of "
        "the ratio of medians (2000 resamples of each side, fixed seed) against 1. Above 1 where the claim says "
        "\"slower\" or \"more\": *confirmed*; below: *refuted*; holding 1: *not separated* (the intervals "
        "overlap). *not reproduced*: our setting differs from the report's in the quantity that decides the claim "
        "(the iteration counts), so the verdict says nothing of the claim's mechanism. *not run*: this machine cannot "
        "run it (no GPU); the row says what would decide it. Numbers: ours as ratio [95% interval] (n = runs of each "
        "side), the report's ratio of its published times beside.")


def claims(preset):
    """The claims table: this machine's verdicts part by part, and for any other machine the reference's."""
    ref = reference()
    other = ref if ref and ref != machine() else None
    rows = claim_rows(preset)
    head = "| claim | part | verdict | the numbers that decide it |" + (f" reference {md(other)} |" if other else "")
    out = [RULE, "", head, "|---|---|---|---|" + ("---|" if other else "")]
    theirs = []
    if other:
        with on(other):
            theirs = claim_rows(preset)
    for i, r in enumerate(rows):
        line = f"| {md(r['claim'])} | {md(r['part'])} | {r['verdict']} | {md(r['numbers'])} |"
        if other:
            match = [t["verdict"] for t in theirs if t["claim"] == r["claim"] and t["part"] == r["part"]]
            line += f" {match[0] if match else '—'} |"
        out.append(line)
    return out


def claim_rows(preset):
    return claims_mod.all_claims(preset)


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
            include("table41_mg", preset),
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
