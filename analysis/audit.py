"""make audit: re-runs a sample of recorded cases on this machine (the command line each record carries) and says,
per case, whether the outcome matches the record and how the time compares."""
import json
import os
import random
import subprocess

import pandas as pd

from analysis.records import RESULTS, ROOT, read_jsonl

MPI_ENV = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1", "OMPI_MCA_rmaps_base_oversubscribe": "1"}


def command(rec):
    """The recorded command line without its outputs (--record FILE), asking for the record on stdout instead."""
    argv, out, skip = rec["argv"], [], False
    for a in argv:
        if skip:
            skip = False
            continue
        if a in ("--record", "--output", "--png", "--snapshots", "--snapshot-prefix", "-o", "--out", "--solution"):
            skip = True
            continue
        if a not in ("--json", "--quiet"):
            out.append(a)
    if rec["app"] == "radiosity" and "formfactors" in argv:
        out += ["-o", "/tmp/hpcgi-audit.ff"]
    if rec.get("params", {}).get("backend") == "mpi":
        out = ["mpirun", "-np", str(rec["params"]["ranks"]), *out]
    return out + ["--json", "--quiet"]


def outcome(rec):
    """What must match: iterations and status exactly, residuals and errors to 1e-6 relative (or within 10 % for
    the few that depend on the order of a parallel reduction)."""
    r = rec.get("result", {})
    keys = ("status", "iterations", "rel_residual", "true_rel_residual", "error_inf", "max_rel_residual", "min_row_sum",
            "max_row_sum")
    return {k: r[k] for k in keys if k in r}


def same(a, b):
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return abs(a - b) <= max(1e-6 * max(abs(a), abs(b)), 1e-12) or (a != 0 and abs(a - b) / abs(a) < 0.1)
    if isinstance(a, list):
        return all(same(x, y) for x, y in zip(a, b))
    return a == b


def run(preset, sample):
    recs = []
    for f in sorted(RESULTS.glob(f"*/{preset}.jsonl")):
        recs += [r for r in read_jsonl(f) if "argv" in r]
    if not recs:
        print(f"audit: no records with a command line for preset {preset}")
        return 1
    random.Random(2014).shuffle(recs)
    rows, bad = [], 0
    for rec in recs[:sample]:
        cmd = command(rec)
        p = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, env=dict(os.environ, **MPI_ENV))
        row = {"case": rec["provenance"].get("env", {}).get("HPCGI_CASE", "-"), "command": " ".join(cmd[:-2])}
        if p.returncode != 0:
            row.update(match="FAILED", detail=p.stderr.strip()[:120])
            bad += 1
        else:
            new = json.loads([l for l in p.stdout.splitlines() if l.startswith("{")][-1])
            old_o, new_o = outcome(rec), outcome(new)
            diff = [k for k in old_o if not same(old_o[k], new_o.get(k))]
            row["match"] = "yes" if not diff else "NO: " + ", ".join(diff)
            bad += bool(diff)
            t_old = rec["times_s"].get("solve", rec["times_s"].get("hemicube", 0))
            t_new = new["times_s"].get("solve", new["times_s"].get("hemicube", 0))
            row["time now / recorded"] = f"{t_new / t_old:.2f}" if t_old else "-"
            row["recorded on"] = rec["provenance"]["host"]
        rows.append(row)
    print(pd.DataFrame(rows).to_markdown(index=False))
    print(f"audit: {len(rows) - bad} of {len(rows)} sampled cases reproduce their recorded outcome")
    return 1 if bad else 0
