"""The settings a table's numbers were made under, in one line under the table (issue 34): its scenes (the report's,
or our stand-ins and why), hemicube weights and resolution, storage of F, tolerance, threads and ranks (ours beside
the report's), preset; and the headers' thread and rank counts."""
import re

import numpy as np

from analysis.escape import md

# The report ran on one maya node: 2 x 8-core E5-2650v2 (16 threads, up to 16 MPI processes) and an NVIDIA K20.
REPORT_THREADS = {"openmp": 16, "serial": 1, "original": 1}
SCENES = {1: "scene 1 (our stand-in, radiosity/scenes/scene1.xml: RRV does not ship the report's)",
          2: "scene 2 (our stand-in, radiosity/scenes/scene2.xml: RRV does not ship the report's)",
          3: "scene 3 (RRV's room3.xml, the report's)", 4: "scene 4 (RRV's room2.xml, the report's)"}


def _natural(text):
    """Numbers in their order (2 before 16), text after them in its own."""
    try:
        return (0, float(text), "")
    except ValueError:
        return (1, 0.0, text)


def _values(df, col, fmt=str):
    if col not in df:
        return None
    vals = sorted({fmt(v) for v in df[col].dropna()}, key=_natural)
    return ", ".join(vals) if vals else None


def line(df, preset, what=None):
    """"Settings: ..." for the records of df (one table's), from the records themselves."""
    parts = [f"preset {md(preset)}"]
    if "scene_id" in df and df["scene_id"].notna().any():
        parts.append("; ".join(SCENES.get(int(s), f"scene {int(s)}") for s in sorted(set(df["scene_id"].dropna()))))
    for col, name, fmt in (("params.weights", "hemicube weights", str), ("params.hemicube", "hemicube resolution",
                                                                          lambda v: str(int(v))),
                           ("params.tol", "tolerance", lambda v: f"{v:g}"), ("params.precision", "precision", str)):
        v = _values(df, col, fmt)
        if v:
            parts.append(f"{name} {md(v)}")
    if "params.storage" in df or "params.ff_precision" in df:
        st = df["params.storage"].fillna("dense") if "params.storage" in df else None
        fp = df["params.ff_precision"].fillna("float32") if "params.ff_precision" in df else None
        if st is not None:
            both = st + " " + (fp if fp is not None else "float32")
            parts.append("F stored " + md(", ".join(sorted(set(both)))))
    th = _values(df, "params.threads", lambda v: str(int(v)))
    if th:
        parts.append(f"ours {th} OpenMP thread(s) on {_values(df, 'provenance.cpus_online', lambda v: str(int(v)))} "
                     "cores, the report's OpenMP 16 threads on 2 x 8 cores")
    if what:
        parts.append(what)
    return "Settings: " + "; ".join(parts) + "."


def threads_of(df, column):
    """The thread or rank count a column of ours ran with, as a header suffix ("" where not known)."""
    if column.startswith("p") and column[1:].isdigit():
        return f" ({column[1:]} rank{'s' if column[1:] != '1' else ''})"
    sel = df[df["column"] == column] if "column" in df else df.iloc[0:0]
    th = sorted({int(v) for v in sel["params.threads"].dropna()}) if "params.threads" in sel else []
    if column in ("serial", "original"):
        return " (1 thread)"
    return f" ({'/'.join(map(str, th))} thread{'s' if th != [1] else ''})" if th else ""


def report_suffix(column):
    if column in REPORT_THREADS:
        n = REPORT_THREADS[column]
        return f" ({n} thread{'s' if n != 1 else ''})"
    if column.startswith("p") and column[1:].isdigit():
        return f" ({column[1:]} rank{'s' if column[1:] != '1' else ''})"
    if column.startswith("cuda") or column.startswith("cublas"):
        return " (K20)"
    return ""


def base(column):
    """A header without its thread or rank suffix: "ours openmp (2 threads)" -> "ours openmp"."""
    return re.sub(r" \([^()]*\)$", "", column)


def finite(x):
    return x is not None and isinstance(x, (int, float, np.floating)) and np.isfinite(x)


def _case_lines(experiment, preset):
    from analysis.records import ROOT
    f = ROOT / "slurm" / "cases" / preset / f"{experiment}.txt" if preset.isidentifier() else None
    if f is None or not f.exists():
        return []
    return [l.split() for l in f.read_text().splitlines() if l.strip() and not l.startswith("#")]


def planned(experiment, preset, what=None):
    """"Settings ...:" for a table whose experiment has no records here, from its case list (slurm/cases/<preset>/)
    and the form-factor records of its scenes: what would run, so that an empty table still names its settings."""
    import pandas as pd
    from analysis.records import SCENE_IDS, load
    lines = _case_lines(experiment, preset)
    if not lines:
        return f"Settings: preset {md(preset)}" + (f"; {what}" if what else "") + "."

    def opt(name, default=None):
        vals = {l[l.index(name) + 1] if name in l[:-1] else default for l in lines}
        return sorted(v for v in vals if v is not None)
    scenes = sorted({a.rsplit("/", 1)[-1] for l in lines for a in l if a.endswith(".xml")})
    cols = {"scene_id": [SCENE_IDS.get(s) for s in scenes]}
    ff = load("formfactors", preset)
    if len(ff) and "params.scene" in ff:
        ff = ff[ff["params.scene"].map(lambda s: str(s).rsplit("/", 1)[-1]).isin(scenes)]
        cols.update({c: sorted(set(ff[c].dropna())) for c in ("params.weights", "params.hemicube") if c in ff})
    cols["params.tol"] = [float(v) for v in opt("--tol")]
    prog = {next((a.rsplit("/", 1)[-1] for a in l[:3] if a.startswith("bin/")), None) for l in lines}  # past repeat=, ranks=
    default = {"poisson": "double", "radiosity": "float"}.get(prog.pop()) if len(prog) == 1 else None
    pairs = sorted({(l[l.index("--storage") + 1], l[l.index("--ff-precision") + 1] if "--ff-precision" in l[:-1]
                     else "float32") for l in lines if "--storage" in l[:-1]})
    cols.update({"params.storage": [a for a, _ in pairs], "params.ff_precision": [b for _, b in pairs],
                 "params.precision": opt("--precision", default)})
    if not any(cols.values()):
        return f"Settings: preset {md(preset)}" + (f"; {what}" if what else "") + "."
    df = pd.concat([pd.Series(v, name=c, dtype=float if c == "params.tol" else object) for c, v in cols.items() if v],
                   axis=1)
    threads = opt("--threads")
    ranks = sorted({a[len("ranks="):] for l in lines for a in l[:2] if a.startswith("ranks=")}, key=_natural)
    runs = "; ".join(x for x in (f"ours {', '.join(sorted(threads, key=_natural))} OpenMP thread(s)" if threads else "",
                                 f"{', '.join(ranks)} MPI rank(s)" if ranks else "") if x)
    head = line(df.dropna(axis=1, how="all"), preset, "; ".join(x for x in (runs, what) if x))
    return head.replace("Settings:", "Settings (of the case list; no runs of it used here):", 1)
