"""report/MACHINES.md: every machine with records in results/, its provenance and its headline numbers side by side
(Table 4.1 at N = 1024, Table 4.2 on scene 3, a Jacobi step of room3, the triad bandwidth), each from that
machine's own records."""
import sys

import pandas as pd

from analysis import protocol, radiosity_tables, table41
from analysis.escape import md, md_table
from analysis.records import (cell, summarise, load, machine, machine_dir, machine_label, machines, on, reference,
                              report_dir)


def describe(label):
    """What machine.json (written by the runner) says of a machine, else what its records' provenance says."""
    d = machine_label.read_owner(machine_dir(label))  # ValueError where it is damaged or no regular file
    if d:
        return d.get("host"), d.get("cpu_model"), d.get("cpus_online"), d.get("gpu"), d.get("caches")
    for exp in ("table41", "table42", "formfactors", "bench-stream"):
        df = load(exp)
        if not df.empty:
            last = df.sort_values("provenance.utc").iloc[-1]
            gpu = last.get("backend_info.gpu") if "backend_info.gpu" in df else None
            return last["provenance.host"], last["provenance.cpu_model"], last["provenance.cpus_online"], gpu, None
    return None, None, None, None, None


def probe_gbs(preset):
    """The median of the current machine's bandwidth probes (the runner's, before and after each timed run of the
    preset: common/timed_run.py), and their count."""
    vals = []
    for f in sorted(machine_dir().glob(f"*/{preset}.state.jsonl")):
        try:
            good, _ = protocol.harness_io.read_objects(f)
        except protocol.harness_io.HarnessFileError:
            continue
        vals += [float(d[k]) for _, d in good for k in ("probe_before_gbs", "probe_after_gbs")
                 if isinstance(d.get(k), (int, float)) and d[k] > 0]
    return (float(pd.Series(vals).median()), len(vals)) if vals else (None, 0)


def differences(preset, ref):
    """One sentence: what differs between the current machine and the reference `ref` that can move a time or a
    claim: the CPU, the cores, the caches and the bandwidth its probes measured."""
    def facts():
        _, cpu, cpus, gpu, cache = describe(machine())
        gbs, n = probe_gbs(preset)
        return {"CPU": cpu, "cores": cpus, "GPU": gpu or "none",
                "caches": ", ".join(f"{k} {v}" for k, v in sorted((cache or {}).items())) or "not recorded",
                "bandwidth probe": f"{gbs:.1f} GB/s (median of {n})" if gbs else "none"}
    mine = facts()
    with on(ref):
        theirs = facts()
    parts = [f"{k} {md(mine[k])} against {md(theirs[k])}" for k in mine if str(mine[k]) != str(theirs[k])]
    same = [k for k in mine if str(mine[k]) == str(theirs[k])]
    return (f"What differs between this machine and the reference {md(ref)}: "
            + ("; ".join(parts) if parts else "nothing this report can see")
            + (f" (the same: {', '.join(same)})" if same else "") + ".")


def headline(preset):
    """The current machine's headline numbers, each a median [95% interval] n ("—" where it has no records of them).
    Table 4.1's is plain CG's fastest column, as the report ran it: MG-PCG, another algorithm, is never its headline."""
    row = {"T4.1 N=1024 s (plain CG)": "—", "T4.1 column": "", "T4.2 scene 3 Jacobi s": "—",
           "T4.2 scene 3 BiCG-STAB s": "—", "Jacobi step room3 ms": "—", "triad GB/s": "—", "records used": 0}
    _, s41 = table41.ours(preset)
    at = s41[(s41["n"] == 1024) & ~s41["column"].str.startswith(table41.MG)] if not s41.empty else s41
    if len(at):
        best = at.loc[at["median"].idxmin()]
        row["T4.1 N=1024 s (plain CG)"], row["T4.1 column"] = cell(best), best["column"]
    t42 = radiosity_tables.solves("table42", preset)
    if not t42.empty and (t42["scene_id"] == 3).any():
        s42 = summarise(t42[t42["scene_id"] == 3], ["params.method"], "time_s").set_index("params.method")
        for m, col in (("jacobi", "T4.2 scene 3 Jacobi s"), ("bicgstab", "T4.2 scene 3 BiCG-STAB s")):
            if m in s42.index:
                row[col] = cell(s42.loc[m])
    jac = load("bench-jacobi", preset)
    if not jac.empty and "params.storage" in jac:
        ours = jac[(jac["app"] == "radiosity") & (jac["params.ff_precision"] == "float32")]
        if len(ours):
            per = ours.assign(ms=1e3 * ours["times_s.per_iteration"])
            s = summarise(per, ["provenance.env.HPCGI_CASE"], "ms")
            row["Jacobi step room3 ms"] = cell(s.loc[s["median"].idxmin()])
    st = load("bench-stream", preset)
    if not st.empty:
        row["triad GB/s"] = cell(summarise(st.assign(k=0), ["k"], "perf.triad_GBps").iloc[0])
    row["records used"] = sum(len(load(e, preset)) for e in ("table41", "table42", "table43", "table44", "table45"))
    return row


def claims_table(preset, labels):
    """Every claim part, one row each: its paired ratio [interval] and verdict on each machine (a machine's folder
    is one run of it: a second run of one machine is a folder of its own)."""
    from analysis import claims
    by = {}
    order = []
    for label in labels:
        with on(label):
            try:
                parts = claims.all_claims(preset)
            except (ValueError, KeyError, TypeError) as e:
                print(f"analysis: machine {label}'s claims left out of MACHINES.md: {e}", file=sys.stderr)
                continue
        for r in parts:
            k = (r["claim"], r["part"])
            if k not in by:
                by[k] = {}
                order.append(k)
            by[k][label] = (f"{r['verdict']}: {r['ratio']:.3g} [{r['low']:.3g}, {r['high']:.3g}] n={r['n']}"
                            if r["n"] else r["verdict"])
    rows = [{"claim": c, "part": p, **{label: by[(c, p)].get(label, "—") for label in labels}} for c, p in order]
    return md_table(pd.DataFrame(rows)) if rows else "none"


def write(preset):
    ref = reference()
    rows, broken = [], []
    for label in machines():
        with on(label):
            try:
                host, cpu, cpus, gpu, cache = describe(label)
                row = {"machine": label + (" (reference)" if label == ref else ""), "host": host, "CPU": cpu,
                       "CPUs": cpus, "caches": ", ".join(f"{k} {v}" for k, v in sorted((cache or {}).items())) or "—",
                       "GPU": gpu or "none", **headline(preset)}
            except (ValueError, KeyError, TypeError) as e:  # one machine's bad folder never hides the others
                print(f"analysis: machine {label} left out of MACHINES.md: {e}", file=sys.stderr)
                broken.append(f"- {md(label)}: left out, {md(e)}")
                continue
        rows.append(row)
    out = report_dir().parent / "MACHINES.md"
    out.parent.mkdir(parents=True, exist_ok=True)
    body = md_table(pd.DataFrame(rows)) if rows else "none"
    if broken:
        body += "\n\nMachines whose folder could not be read:\n\n" + "\n".join(broken)
    out.write_text(
        f"# Machines with records ({preset} preset)\n\n"
        "Every folder of `results/` is one machine's records (`results/<machine>/<experiment>/<preset>.jsonl`, "
        "made there by `make reproduce` and `make bench`); a machine's report is "
        "`report/<machine>/REPORT-<preset>.md`. Headline numbers, each the median of that machine's own records: "
        "Table 4.1 at N = 1024 (setup + solve of its fastest plain-CG column, as the report ran it; MG-PCG is in the "
        "report's own table), Table 4.2 on scene 3 (RRV's room3.xml, OpenMP, "
        "to 1e-6), one Jacobi step of room3 with F in float32 (`make bench`, our fastest layout) and the STREAM triad "
        f"(`bin/stream`, `make bench`). Each is median [interval of the median] n=runs; records used: the records "
        "of Tables 4.1-4.5 the tables use (from clean commits, not disturbed). Written by `make machines` from the "
        f"records.\n\n{body}\n\n"
        "## The claims on every machine\n\n"
        "Each claim part's paired ratio [distribution-free interval] n=pairs and its verdict by the one rule "
        "(analysis/verdict.py; each machine's report says its margin), on each machine folder (one run each; a "
        "second run of one machine has a folder of its own). Where a claim differs between machines, compare their "
        "bandwidth probes, cores and caches (the columns above and each report's provenance): "
        "`python -m analysis.reproducibility --claims A B` names the parts that differ.\n\n"
        f"{claims_table(preset, [r['machine'].replace(' (reference)', '') for r in rows])}\n")
    return out
