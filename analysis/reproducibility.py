"""Does the timing protocol reproduce itself? Two runs of one preset's timed experiments (two machine folders of
records, e.g. the reference's and a fresh clone's on the same machine an hour later) compared group by group: the
share of timed groups whose 95% intervals of the median overlap (issue 31 asks for at least 90%).

    python -m analysis.reproducibility FOLDER_A FOLDER_B [PRESET]     (default quick)

A group is one case (its HPCGI_CASE) of a timed experiment, its runs the answers (exit status 0) that were not
flagged as disturbed; its interval is the protocol's (common/timing_protocol.py). Prints one line per group that
does not overlap, each folder's summary (how its groups ended, from its state files) and the share that overlaps;
exit 0 when the share is at least 90%, 1 when not, 2 on bad arguments."""
import json
import sys
from pathlib import Path

from analysis.protocol import timing_protocol as tp

TIMED = ("table41", "table42", "table43", "table44", "table45", "mpi-formfactors", "mpi-radiosity")


def groups(folder, preset):
    """{(experiment, case): [times]} of the folder's timed experiments."""
    out = {}
    for exp in TIMED:
        rec_file = Path(folder) / exp / f"{preset}.jsonl"
        if not rec_file.exists():
            continue
        disturbed = {(s["case"], s["repeat"]) for s in tp.read_lines(Path(folder) / exp / f"{preset}.state.jsonl")
                     if "repeat" in s and s.get("disturbed")}
        for r in tp.read_lines(rec_file):
            env = (r.get("provenance") or {}).get("env") or {}
            case, rep = env.get("HPCGI_CASE"), str(env.get("HPCGI_REPEAT", ""))
            t = tp.timed_value(r)
            if (case is None or t is None or (r.get("result") or {}).get("exit_status", 0) != 0 or not rep.isdigit()
                    or (case, int(rep)) in disturbed):
                continue
            out.setdefault((exp, case), []).append(t)
    return out


def summary(folder, preset):
    """How the folder's timed groups ended, from its state files: groups that met the interval target and groups
    that stopped at the cap, timed runs and those flagged as disturbed, the hours they ran in (UTC), and the median of
    the bandwidth probes before the runs (GB/s: on a shared VM the host's bandwidth moves from hour to hour)."""
    s = {"met": 0, "capped": 0, "timed_runs": 0, "disturbed": 0, "first_utc": None, "last_utc": None}
    probes = []
    for exp in TIMED:
        for line in tp.read_lines(Path(folder) / exp / f"{preset}.state.jsonl"):
            if "stop" in line:
                s["met" if line["stop"] == "interval" else "capped"] += 1
            elif "repeat" in line:
                s["timed_runs"] += 1
                s["disturbed"] += bool(line.get("disturbed"))
                if isinstance(line.get("probe_before_gbs"), (int, float)):
                    probes.append(line["probe_before_gbs"])
                utc = line.get("utc")
                if utc:
                    s["first_utc"] = min(s["first_utc"] or utc, utc)
                    s["last_utc"] = max(s["last_utc"] or utc, utc)
    s["probe_median_gbs"] = round(tp.median(probes), 2) if probes else None
    return s


def compare(a, b):
    """(groups in both, [(key, median_a, ci_a, median_b, ci_b) of those whose intervals do not overlap])."""
    both = sorted(k for k in a.keys() & b.keys() if len(a[k]) >= 3 and len(b[k]) >= 3)
    apart = []
    for k in both:
        (la, ha), (lb, hb) = tp.median_ci(a[k]), tp.median_ci(b[k])
        if ha < lb or hb < la:
            apart.append((k, tp.median(a[k]), (la, ha), tp.median(b[k]), (lb, hb)))
    return both, apart


def main(argv):
    if len(argv) not in (2, 3) or not all(Path(p).is_dir() for p in argv[:2]):
        print(__doc__.split("\n\n")[1], file=sys.stderr)
        return 2
    preset = argv[2] if len(argv) == 3 else "quick"
    both, apart = compare(groups(argv[0], preset), groups(argv[1], preset))
    if not both:
        print("reproducibility: no timed group with 3 runs or more in both folders", file=sys.stderr)
        return 2
    for folder in argv[:2]:
        print(json.dumps({"folder": folder, **summary(folder, preset)}))
    for (exp, case), ma, ca, mb, cb in apart:
        print(f"apart: {case}: {ma:.4g} [{ca[0]:.4g}, {ca[1]:.4g}] against {mb:.4g} [{cb[0]:.4g}, {cb[1]:.4g}] s")
    share = 1 - len(apart) / len(both)
    print(json.dumps({"groups": len(both), "overlapping": len(both) - len(apart), "share": round(share, 3)}))
    return 0 if share >= 0.9 else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
