#!/usr/bin/env python3
"""How long a preset will take on this machine, from this machine's own records of a smaller preset (quick).

    python3 common/estimate.py PRESET [--from quick] [--per-case FILE] EXPERIMENT...
    env: RESULTS (results), MACHINE (this machine's label), REPEAT (as slurm/run-case), RRV_SCENES

For every case of slurm/cases/PRESET/EXPERIMENT.txt: whether this machine runs it (a GPU case without a GPU, a case
with more ranks than cores, one that needs RRV's scenes where there are none: skipped, as slurm/run-case skips
them), how many runs (the list's "# repeat: N" or REPEAT, capped by the line's repeat=K) and how long one run takes.
A run's time is the median wall time of the same case in the smaller preset, that is the same line up to its sizes
(--n, the scene, --hemicube, --divide, --steps, the files, --threads, --weights), scaled to the larger size by the work a run
does:
  Poisson, plain CG:                 iterations ~ N, work per iteration ~ N^2:  (N / N0)^3
  Poisson, MG-PCG or FMG:            iterations about constant:                 (N / N0)^2
  radiosity solve, relight:          dense F, P^2 per step (the same steps):    (P / P0)^2 x steps / steps0
  radiosity formfactors (hemicube):  each patch renders every patch into R^2:   P (P + 3 R^2) / P0 (P0 + 3 R0^2)
where P is the scene's patch count (bin/radiosity info). A case with no such twin in the smaller preset's records has
no estimate and is listed. Standard library only; prints one table and, last, the total.
--per-case FILE writes "EXPERIMENT/INDEX RUNS SECONDS_PER_RUN" per case (SECONDS_PER_RUN is "-" without an estimate),
which slurm/run-local reads for its progress lines."""
import argparse
import json
import os
import re
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from common import harness_io  # noqa: E402
from gpukit import cases  # noqa: E402

# options whose values are sizes or files, or (--weights) change no work
SIZES = {"--n", "--hemicube", "--divide", "--steps", "--ff", "-o", "--basis", "--reference-ff", "--threads",
         "--snapshot-prefix", "--random-frames", "--frames", "--weights"}
DEFAULT_REPEAT = 5  # slurm/run-case's, for a list without "# repeat: N"
PROBE_S = 1.0  # the bandwidth probes before and after a timed run, and the runner's own steps


def shape(command):
    """A command up to its sizes: the values of SIZES, the scene and any file named after its preset as '*'; without
    --min-time S, which changes how a solve is timed, not its work (estimate adds S)."""
    words, out = [w for w in command.split() if w != "--allow-reflectivity-ge-1"], []  # the scene's, as its name
    for k, w in enumerate(words):
        if w == "--min-time" or (k and words[k - 1] == "--min-time"):
            continue
        if k and words[k - 1] in SIZES:
            out.append("*")
        elif re.search(r"\.(xml|obj|json|ff)$", w):
            out.append("*")
        else:
            out.append(w)
    return " ".join(out)


def opt(command, name, cast=str, default=None):
    w = command.split()
    return cast(w[w.index(name) + 1]) if name in w[:-1] else default


class Machine:
    """What this machine can run and the patch counts of the scenes it is asked about."""

    def __init__(self, tokens):
        self.cores = cases.cores()
        self.tokens = tokens
        self.gpu = _has_gpu()
        self.rrv = bool(tokens.get("RRV_SCENES")) and Path(tokens["RRV_SCENES"], "room3.xml").is_file()
        self._patches = {}

    def skip(self, case):
        """Why this machine skips the case (as slurm/run-case does), or None."""
        ranks = case.prefixes.get("ranks")
        if ranks and int(cases.replace(ranks, self.tokens)) > self.cores:
            return "cores"
        if case.is_gpu() and not self.gpu:
            return "gpu"
        if "{RRV_SCENES}" in case.command and not self.rrv:
            return "rrv"
        return None

    def patches(self, command):
        """The scene's patch count after --divide (bin/radiosity info), or None."""
        words = cases.replace(command, self.tokens).split()
        scene = next((w for w in words if w.endswith(".xml")), None)
        if scene is None:
            return None
        key = (scene, opt(command, "--divide", float, 1.0), "--allow-reflectivity-ge-1" in words)
        if key not in self._patches:
            argv = [str(ROOT / "bin" / "radiosity"), "info", scene, "--divide", f"{key[1]:g}", "--json", "--quiet"]
            argv += ["--allow-reflectivity-ge-1"] if key[2] else []
            try:
                p = subprocess.run(argv, capture_output=True, text=True, timeout=120)
                self._patches[key] = json.loads(p.stdout)["result"]["patches"] if p.returncode == 0 else None
            except (OSError, subprocess.TimeoutExpired, ValueError, KeyError):
                self._patches[key] = None
        return self._patches[key]


def _has_gpu():
    try:
        p = subprocess.run(["nvidia-smi", "-L"], capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return p.returncode == 0 and "GPU" in p.stdout


def list_repeat(path):
    m = re.search(r"^# repeat: *([0-9]+)", path.read_text(), re.M)
    return int(m[1]) if m else DEFAULT_REPEAT


def walls(mdir, exp, preset):
    """Each case id's wall seconds a run on this machine: the timed runs' state lines (the whole run, launcher
    included), else the records' own total."""
    out = {}
    state, _ = harness_io.read_objects(mdir / exp / f"{preset}.state.jsonl")
    for _, s in state:
        if isinstance(s.get("wall_s"), (int, float)) and s.get("exit_status") == 0:
            out.setdefault(str(s.get("case")), []).append(float(s["wall_s"]))
    if out:
        return out
    recs, _ = harness_io.read_objects(mdir / exp / f"{preset}.jsonl")
    for _, r in recs:
        case = str(((r.get("provenance") or {}).get("env") or {}).get("HPCGI_CASE", ""))
        t = (r.get("times_s") or {}).get("total")
        if case and isinstance(t, (int, float)):
            out.setdefault(case, []).append(float(t))
    return out


def scale(target, source, machine):
    """The factor from the source case's run to the target's (the module's docstring), or None."""
    t, s = target.command, source.command
    if "bin/poisson" in t:
        n, n0 = opt(t, "--n", int), opt(s, "--n", int)
        if not n or not n0:
            return 1.0 if n == n0 else None
        k = 2 if "--precond mg" in t or "--method fmg" in t else 3
        return (n / n0) ** k
    if "bin/radiosity" in t:
        p, p0 = machine.patches(t), machine.patches(s)
        if not p or not p0:
            return None
        if " formfactors " in f" {t} ":
            r, r0 = opt(t, "--hemicube", int, 256), opt(s, "--hemicube", int, 256)
            return p * (p + 3 * r * r) / (p0 * (p0 + 3 * r0 * r0))
        steps, steps0 = opt(t, "--steps", int), opt(s, "--steps", int)
        return (p / p0) ** 2 * (steps / steps0 if steps and steps0 else 1.0)
    n, n0 = opt(t, "--n", int), opt(s, "--n", int)
    return (n / n0) ** 2 if n and n0 else 1.0


def estimate(preset, source, experiments, results, machine_label, tokens):
    machine = Machine(tokens)
    mdir = Path(results) / machine_label
    rows = []
    for exp in experiments:
        path = ROOT / "slurm" / "cases" / preset / f"{exp}.txt"
        runs_default = int(os.environ["REPEAT"]) if os.environ.get("REPEAT", "").isdigit() else list_repeat(path)
        timed = list_repeat(path) > 1
        src_path = ROOT / "slurm" / "cases" / source / f"{exp}.txt"
        src_cases = cases.read(src_path, source) if src_path.is_file() else []
        wall = walls(mdir, exp, source) if src_cases else {}
        twins = {}
        for c in src_cases:
            if wall.get(c.case_id):
                key = (shape(c.command), c.prefixes.get("ranks"))
                twins.setdefault(key, []).append((c, statistics.median(wall[c.case_id])))
        for case in cases.read(path, preset):
            why = machine.skip(case)
            runs = min(runs_default, int(case.prefixes.get("repeat", runs_default)))
            row = {"experiment": exp, "index": case.index, "runs": 0 if why else runs, "skip": why, "seconds": None}
            if not why:
                ranks = case.prefixes.get("ranks")
                ranks = cases.replace(ranks, tokens) if ranks else None
                found = twins.get((shape(case.command), ranks), [])
                best = None
                for src, secs in found:  # the twin nearest in size: the smallest factor above 1, else the largest
                    f = scale(case, src, machine)
                    if f is not None and (best is None or abs(f - 1) < abs(best[0] - 1)):
                        best = (f, secs, src)
                if best:
                    # --min-time S: a short solve is repeated for about S seconds more (a long one runs once)
                    more = opt(case.command, "--min-time", float, 0.0) - opt(best[2].command, "--min-time", float, 0.0)
                    row["seconds"] = best[0] * best[1] + max(0.0, more) + (PROBE_S if timed else 0.0)
            rows.append(row)
    return rows


def hms(s):
    s = int(round(s))
    return f"{s // 3600}h{s % 3600 // 60:02d}m" if s >= 3600 else f"{s // 60}m{s % 60:02d}s"


def main(argv):
    ap = argparse.ArgumentParser(prog="common/estimate.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("preset")
    ap.add_argument("experiments", nargs="+")
    ap.add_argument("--from", dest="source", default="quick", help="the smaller preset whose records it scales")
    ap.add_argument("--per-case", help="write EXPERIMENT/INDEX RUNS SECONDS_PER_RUN per case to this file")
    ap.add_argument("--quiet", action="store_true", help="print nothing (with --per-case)")
    a = ap.parse_args(argv)
    for name in (a.preset, a.source):
        if not re.fullmatch(r"[a-z]+", name) or not (ROOT / "slurm" / "cases" / name).is_dir():
            print(f"estimate: no preset {name!r} (slurm/cases/)", file=sys.stderr)
            return 2
    for exp in a.experiments:
        if not re.fullmatch(r"[a-z0-9-]+", exp) or not (ROOT / "slurm" / "cases" / a.preset / f"{exp}.txt").is_file():
            print(f"estimate: no experiment {exp!r} in the {a.preset} preset", file=sys.stderr)
            return 2
    label = os.environ.get("MACHINE")
    if not label:
        p = subprocess.run([sys.executable, str(ROOT / "common" / "machine_label.py")], capture_output=True, text=True)
        label = p.stdout.strip()
    rrv = subprocess.run([str(ROOT / "radiosity" / "scenes" / "rrv" / "dir")], capture_output=True, text=True)
    tokens = {"RRV_SCENES": rrv.stdout.strip() if rrv.returncode == 0 else "", "PRESET": a.preset,
              "FF_DIR": os.environ.get("FF_DIR") or "build/ff"}
    rows = estimate(a.preset, a.source, a.experiments, os.environ.get("RESULTS") or "results", label, tokens)
    lines = [f"estimate: the {a.preset} preset on {label}, from its own {a.source} records "
             f"(common/estimate.py: the same case at its {a.source} size, scaled by its work)",
             f"  {'experiment':<28} {'cases':>5} {'runs':>5} {'skipped':>7} {'no estimate':>11} {'time':>9}"]
    total, unknown = 0.0, []
    for exp in a.experiments:
        mine = [r for r in rows if r["experiment"] == exp]
        secs = sum(r["runs"] * r["seconds"] for r in mine if r["seconds"] is not None)
        missing = [r for r in mine if not r["skip"] and r["seconds"] is None]
        unknown += missing
        total += secs
        lines.append(f"  {exp:<28} {len(mine):>5} {sum(r['runs'] for r in mine):>5} "
                     f"{sum(1 for r in mine if r['skip']):>7} {len(missing):>11} {hms(secs):>9}")
    if unknown:
        names = " ".join(f"{r['experiment']}/{r['index']}" for r in unknown[:12])
        lines.append(f"  no estimate for {len(unknown)} case(s) (no twin among this machine's {a.source} records): "
                     f"{names}{' ...' if len(unknown) > 12 else ''}")
    lines.append(f"estimate: total {hms(total)} of machine time for the cases with an estimate"
                 f"{f', and {len(unknown)} case(s) more' if unknown else ''}")
    if a.per_case:
        text = "".join(f"{r['experiment']}/{r['index']} {r['runs']} "
                       f"{'-' if r['seconds'] is None else format(r['seconds'], '.3f')}\n" for r in rows)
        try:
            Path(a.per_case).write_text(text)
        except OSError as e:
            print(f"estimate: cannot write {a.per_case}: {e.strerror}", file=sys.stderr)
            return 1
    if not a.quiet:
        print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
