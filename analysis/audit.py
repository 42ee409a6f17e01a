"""make audit: re-runs a sample of recorded cases on this machine (the command line each record carries) and says,
per case, whether the outcome matches the record and how the time compares. The form-factor files a case reads
are made first where they are missing (a fresh checkout), by the recorded case that wrote them."""
import json
import os
import random
import subprocess
import sys

import pandas as pd

from analysis.records import ROOT, machine_dir, read_jsonl

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


def inputs(argv):
    """The form-factor files a command reads."""
    return [argv[k + 1] for k, a in enumerate(argv[:-1]) if a in ("--ff", "--reference-ff")]


def maker_command(rec):
    """The command of a recorded case that wrote a form-factor file: as recorded, -o kept (the file is what is
    wanted), its record left out, under mpirun with its ranks where it ran on several."""
    argv, out, skip = rec["argv"], [], False
    for a in argv:
        if skip:
            skip = False
        elif a == "--record":
            skip = True
        elif a != "--json":
            out.append(a)
    ranks = int(rec.get("params", {}).get("ranks", 1) or 1)
    return (["mpirun", "-np", str(ranks)] if ranks > 1 else []) + out


def make_inputs(rec, recs):
    """Makes the form-factor files a case reads where they are missing (a fresh checkout has no build/ff) by the
    recorded case that wrote them. Returns None, or why it could not."""
    for path in inputs(rec["argv"]):
        if (ROOT / path).exists():
            continue
        maker = next((r for r in recs if "-o" in r["argv"][:-1] and r["argv"][r["argv"].index("-o") + 1] == path),
                     None)
        if maker is None:
            return f"{path} is missing and no record of this preset wrote it"
        cmd = maker_command(maker)
        print(f"audit: making {path}: {' '.join(cmd)}", file=sys.stderr, flush=True)
        (ROOT / path).parent.mkdir(parents=True, exist_ok=True)
        p = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, env=dict(os.environ, **MPI_ENV))
        if p.returncode != 0:
            return f"making {path} failed: {p.stderr.strip()[:120]}"
    return None


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
    for f in sorted(machine_dir().glob(f"*/{preset}.jsonl")):
        recs += [r for r in read_jsonl(f) if "argv" in r]
    if not recs:
        print(f"audit: no records with a command line for preset {preset}")
        return 1
    random.Random(2014).shuffle(recs)
    rows, bad = [], 0
    for rec in recs[:sample]:
        cmd = command(rec)
        row = {"case": rec["provenance"].get("env", {}).get("HPCGI_CASE", "-"), "command": " ".join(cmd[:-2])}
        missing = make_inputs(rec, recs)
        if missing:
            row.update(match="FAILED", detail=missing)
            bad += 1
            rows.append(row)
            continue
        p = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, env=dict(os.environ, **MPI_ENV))
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
