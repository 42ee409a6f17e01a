"""The reproduced report of one machine: report/<machine>/REPORT-<preset>.md with the machine's provenance, every
table and figure beside the report's numbers (and the reference machine's, for any other machine), and for each
claim of the report whether this machine's records confirm it, refute it, or cannot say, the reference machine's
verdict beside it."""
import os

import pandas as pd

from analysis.escape import md
from analysis import accuracy, mpi_radiosity, table42_audit
from analysis import claims as claims_mod
from analysis import machines as machines_mod
from analysis import consistency, protocol, settings
from analysis.records import NONE_USED, ROOT, load, machine, machine_dir, on, plots_dir, reference, report_dir, skipped, \
    tables_dir

EXPERIMENTS = ("table41", "formfactors", "table42", "table43", "table44", "table45", "figure42", "mpi-formfactors",
               "mpi-radiosity", "mpi-large")


def preset_experiments(preset):
    """The experiments of a preset: slurm/cases/<preset>/*.txt (those of EXPERIMENTS where the preset has no list)."""
    d = ROOT / "slurm" / "cases" / preset
    names = sorted(f.stem for f in d.glob("*.txt")) if preset.isidentifier() and d.is_dir() else []
    return names or list(EXPERIMENTS)


def experiments(preset):
    """Per experiment of the preset: its records in the files (every commit), those the tables use, those left out
    and the cases skipped; and the frame of the used records of the report's tables, for the provenance."""
    rows, used = [], []
    for e in preset_experiments(preset):
        every, df = load(e, preset, history=True), load(e, preset)
        f = str(machine_dir() / e / f"{preset}.jsonl")
        left = sum(protocol.COUNTS.get(f, {}).get(k, 0) for k in protocol.LEFT_OUT)
        sk = skipped(e, preset)
        why = "; ".join(f"{len(g)} skipped: {md(r)}" for r, g in sk.groupby("reason")) if len(sk) else ""
        state = "ran" if len(df) else ("no records used: all left out" if len(every) else "did not run")
        rows.append(f"| {md(e)} | {state} | {len(every)} | {len(df)} | {left} | {why} |")
        if len(df) and e in EXPERIMENTS:
            used.append(df.dropna(axis=1, how="all"))
    table = ["| experiment | status | records in the file (every commit) | used (newest commit of each case) | "
             "left out (dirty tree, unknown commit, disturbed) | cases not run |", "|---|---|---:|---:|---:|---|",
             *rows]
    return table, (pd.concat(used, ignore_index=True) if used else pd.DataFrame())


def drift_sentence(preset):
    """How far this machine's times moved between its committed runs of different hours (analysis/reproducibility)."""
    from analysis import reproducibility
    runs = reproducibility.same_machine_runs(machine(), preset)
    d = reproducibility.drift(preset)
    if d is None:
        return ("This machine has one committed run of this preset, so how far its times move from one hour to "
                "another is not measured here; the claims take the margin of 5%.")
    return (f"Between this machine's {len(runs)} committed runs of this preset ({md(', '.join(runs))}), the median of "
            f"a timed group moved by {d:.1%} (the median over the groups of |change|): a time here is that much of a "
            "time on another day; the claims' ratios, paired in the same rounds, travel better.")


def how_to_read(preset, df, differ):
    """The section that says what the report is made of: records, machine, state, protocol, commit, exclusions."""
    out = ["## How to read this report", "",
           "- **A record** is one run's line in `results/<machine>/<experiment>/<preset>.jsonl` (one JSON object: "
           "what ran, what came out, its times, its provenance). Every count of records in this report is of such "
           "lines; \"used\" means used by the tables after the exclusions below.",
           f"- **The machine**: {md(machine())}. "
           + ("This is the reference machine." if reference() == machine() else
              f"The reference machine, beside which its numbers are set: {md(reference() or 'none')}."),
           "- **The protocol** (docs: Hoefler and Belli, SC15; DESIGN.md \"Measurement protocol\"): records from a "
           "working tree with uncommitted changes or from a commit not in this repository are left out; a run the "
           "runner flagged as disturbed (CPU pressure, others' CPU share, steal, bandwidth probe) is left out of the "
           "medians; every timing is the median with the distribution-free interval of the median, its true coverage "
           "where the count cannot reach 95%, and n; a group whose interval is not within +-5% of its median (or that "
           "stopped at its cap) is marked capped; claims are decided by the rule in \"Claims of the report\". Runs "
           "that are no answer (exit status 3, 4, 5) are left out and named under their table.",
           "- **Absolute times carry their condition**: an interval describes the minutes it was measured in. "
           + drift_sentence(preset)]
    if df.empty:
        return out + ["- No records used: run `make reproduce PRESET=" + md(preset) + "`.", ""]
    for col, what in (("provenance.host", "host"), ("provenance.cpu_model", "CPU"), ("provenance.cpus_online", "CPUs"),
                      ("provenance.compiler", "compiler"), ("provenance.git_commit", "commits of the records used"),
                      ("backend_info.gpu", "GPU"), ("backend_info.mpi_library", "MPI")):
        if col in df.columns:
            vals = sorted({str(v) for v in df[col].dropna()})
            out.append(f"- {what}: {md(', '.join(vals)) if vals else 'none'}")
    if "backend_info.gpu" not in df.columns:
        out.append("- GPU: none used (no GPU records)")
    if "provenance.utc" in df.columns:
        out.append(f"- the hours the records used were made in: UTC {md(df['provenance.utc'].min())} to "
                   f"{md(df['provenance.utc'].max())}; a run the runner flagged as disturbed (other processes' CPU "
                   "share, CPU pressure, tasks runnable beside it, steal, the bandwidth probes) is not among them")
    if reference() and reference() != machine():
        out.append(f"- {machines_mod.differences(preset, reference())}")
    cost = protocol.machine_time(machine_dir(), preset)
    if cost["runs"]:
        out.append(f"- what this preset cost the machine: {cost['seconds'] / 3600:.2f} h of runs ({cost['runs']} runs, "
                   f"every record of the preset, used or not: the state files' wall times, the records' own for the "
                   f"untimed runs), UTC {md(cost['first'] or '?')} to {md(cost['last'] or '?')}, from commit(s) "
                   f"{md(', '.join(sorted(cost['commits'])) or 'none')}; {cost['disturbed']} run(s) flagged disturbed "
                   "and left out")
    out += [f"- the same quantity quoted with different settings, or too few runs to check: {md(d)}" for d in differ]
    return out + [""]


# A table's title and the experiment whose case list says its settings, for a table that has no records here.
EMPTY = {"table41": ("Table 4.1: Poisson CG to 1e-6, run time in s", "table41"),
         "table41_mg": ("MG-PCG: Poisson CG preconditioned by one multigrid V-cycle", "table41"),
         "poisson_methods": ("Time to solution per method: Poisson to 1e-6", "table41"),
         "table42": ("Table 4.2: OpenMP Jacobi vs. BiCG-STAB to 1e-6", "table42"),
         "table43": ("Table 4.3: AOS Jacobi to 1e-6", "table43"), "table44": ("Table 4.4: SOA Jacobi to 1e-6", "table44"),
         "table45": ("Table 4.5: hybrid CPU/GPU Jacobi", "table45"),
         "accuracy_cheapest": ("Cheapest setting that reaches each error", "accuracy-tolerance"),
         "accuracy_room3_storage": ("room3.xml: form factors in dense and CSR storage", "accuracy-threshold"),
         "extremes": ("Extremes", "extremes"), "mpi_radiosity": ("Radiosity across MPI ranks", "mpi-radiosity"),
         "relight": ("Relighting", "relight"), "bench_relight": ("Product with k right-hand sides", "bench-relight"),
         "bench": ("make bench", "bench-stream")}


def include(name, preset):
    f = tables_dir() / f"{name}_{preset}.md"
    if f.exists():
        return f.read_text()
    title, experiment = EMPTY.get(name, (name, None))
    planned = f"\n{settings.planned(experiment, preset)}" if experiment else ""
    return f"### {md(title)} ({md(preset)})\n\nNo records used for this preset ({NONE_USED}).{planned}\n"


def image(name, preset, alt):
    f = plots_dir() / f"{name}_{preset}.png"
    return f"![{alt}]({os.path.relpath(f, report_dir())})\n" if f.exists() else f"({alt}: no records used)\n"


RULE = ("Each claim is decided part by part on this machine's records by one rule (analysis/verdict.py): A and B "
        "ran in the same rounds (the order reversed from round to round), and the part is decided on the per-round "
        "ratios A_r / B_r: their median and its distribution-free interval (order statistics, exact for any "
        "distribution; its true coverage is given, and is below 95% where there are fewer than 6 pairs). With a "
        "margin m (5%, or this machine's run-to-run drift where larger): *confirmed* when the interval lies beyond "
        "1 + m on the side the claim says, *refuted* when it lies beyond it on the other side, *equivalent* when it "
        "lies within [1/(1+m), 1+m], *undecided* otherwise; *not run* where this machine has no runs of a side (the "
        "row says what would decide it). What our setting changes (our iteration counts against the report's) is "
        "said beside the verdict, never instead of it. The report's own ratio of its published times stands beside "
        "ours.")


def claims(preset):
    """The claims table: this machine's verdicts part by part, and for any other machine the reference's."""
    from analysis import claims as claims_pkg
    ref = reference()
    other = ref if ref and ref != machine() else None
    rows = claim_rows(preset)
    m = claims_pkg.margin()
    head = "| claim | part | verdict | the numbers that decide it | beside the verdict |" + \
        (f" reference {md(other)} |" if other else "")
    out = [RULE, "", f"The margin on this machine: {m:.1%}.", "", head, "|---|---|---|---|---|" + ("---|" if other else "")]
    theirs = []
    if other:
        with on(other):
            theirs = claim_rows(preset)
    for r in rows:
        line = f"| {md(r['claim'])} | {md(r['part'])} | {r['verdict']} | {md(r['numbers'])} | {md(r['note'])} |"
        if other:
            match = [t["verdict"] for t in theirs if t["claim"] == r["claim"] and t["part"] == r["part"]]
            line += f" {match[0] if match else '—'} |"
        out.append(line)
    return out


def claim_rows(preset):
    return claims_mod.all_claims(preset)


def write(preset):
    ex_table, used = experiments(preset)
    differ = consistency.check(consistency.load(preset))
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
           *how_to_read(preset, used, differ),
           f"## Experiments of this preset ({md(preset)})", "", *ex_table, "",
           "## Claims of the report", "", *claims(preset)]
    out += ["", "## Poisson CG", "", include("table41", preset), image("figure41", preset, "Figure 4.1"),
            include("table41_mg", preset), include("poisson_methods", preset),
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
