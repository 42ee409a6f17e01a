"""Does the timing protocol reproduce itself? Two runs of one preset's timed experiments (two machine folders of
records, e.g. one machine's runs two hours apart, or two machines of a kind) compared group by group: the share of
timed groups whose intervals of the median overlap (issue 31 asks for at least 90%); and with --claims, the claims
(issue 49): how many verdicts flip (confirmed to refuted or back), how many change (decided to undecided or
equivalent, or back), and the share of paired-ratio intervals that overlap.

    python -m analysis.reproducibility FOLDER_A FOLDER_B [PRESET]             (default quick)
    python -m analysis.reproducibility --claims LABEL_A LABEL_B [PRESET]      machine folders of results/ (RESULTS)

A group is one case (its HPCGI_CASE) of a timed experiment, its runs the answers (exit status 0) that were not
flagged as disturbed; its interval is the protocol's (common/timing_protocol.py). Prints one line per group that
does not overlap, each folder's summary (how its groups ended, from its state files) and the share that overlaps;
exit 0 when the share is at least 90%, 1 when not, 2 on bad arguments. --claims prints every claim part whose
verdict differs, then, last, one JSON line {"claims", "flips", "changed", "overlap_share"}.

drift() is the margin's measure (analysis/claims.py): the median relative change of the current machine's timed
groups' medians between its committed runs (its folders whose machine.json names the same machine), or None where
it has one run only."""
import json
import math
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


def same_machine_runs(label, preset):
    """The folders of results/ that hold runs of the machine of `label` (its machine.json's owner) of `preset`."""
    from analysis import records
    try:
        me = records.machine_label.read_owner(records.machine_dir(label))
    except ValueError:
        return []
    key = me.get("machine_id_sha256") or (records.machine_label.digest(me["machine_id"]) if me.get("machine_id") else None)
    out = []
    for other in records.machines():
        try:
            d = records.machine_label.read_owner(records.machine_dir(other))
        except ValueError:
            continue
        k = d.get("machine_id_sha256") or (records.machine_label.digest(d["machine_id"]) if d.get("machine_id") else None)
        if key and k == key and any(records.machine_dir(other).glob(f"*/{preset}.state.jsonl")):
            out.append(other)
    return out


def drift(preset="quick"):
    """The median |relative change| of the current machine's timed groups' medians between its committed runs of
    `preset` (pairs of its folders), or None where it has fewer than two."""
    from analysis import records
    runs = same_machine_runs(records.machine(), preset)
    changes = []
    for i, a in enumerate(runs):
        for b in runs[i + 1:]:
            ga, gb = groups(records.machine_dir(a), preset), groups(records.machine_dir(b), preset)
            for k in ga.keys() & gb.keys():
                if len(ga[k]) >= 3 and len(gb[k]) >= 3:
                    changes.append(abs(math.log(tp.median(ga[k]) / tp.median(gb[k]))))
    return math.exp(tp.median(changes)) - 1 if changes else None


def compare_claims(label_a, label_b, preset):
    """(parts in both, flips, changed, overlapping, rows of the parts that differ) of two machine folders' claims."""
    from analysis import claims, records, verdict
    with records.on(label_a):
        a = {(r["claim"], r["part"]): r for r in claims.all_claims(preset)}
    with records.on(label_b):
        b = {(r["claim"], r["part"]): r for r in claims.all_claims(preset)}
    decided = verdict.VERDICTS[:2]  # confirmed, refuted
    both = [k for k in a if k in b and verdict.VERDICTS[4] not in (a[k]["verdict"], b[k]["verdict"])]
    flips = [k for k in both if {a[k]["verdict"], b[k]["verdict"]} == set(decided)]
    changed = [k for k in both if k not in flips and (a[k]["verdict"] in decided) != (b[k]["verdict"] in decided)]
    ints = [k for k in both if all(math.isfinite(x[k][f]) for x in (a, b) for f in ("low", "high"))]
    overlap = [k for k in ints if not (a[k]["high"] < b[k]["low"] or b[k]["high"] < a[k]["low"])]
    rows = [(k, a[k], b[k]) for k in both if a[k]["verdict"] != b[k]["verdict"]]
    return both, flips, changed, (len(overlap), len(ints)), rows


def main(argv):
    if argv[:1] == ["--claims"]:
        if len(argv) not in (3, 4):
            print(__doc__.split("\n\n")[1], file=sys.stderr)
            return 2
        preset = argv[3] if len(argv) == 4 else "quick"
        from analysis import records
        for label in argv[1:3]:
            if not records.machine_dir(label).is_dir():
                print(f"reproducibility: no machine folder {label} in {records.RESULTS}", file=sys.stderr)
                return 2
        both, flips, changed, (n_over, n_int), rows = compare_claims(argv[1], argv[2], preset)
        for (claim, what), ra, rb in rows:
            print(f"differs: {claim} / {what}: {ra['verdict']} ({ra['numbers']}) against {rb['verdict']} "
                  f"({rb['numbers']})")
        print(json.dumps({"claims": len(both), "flips": len(flips), "changed": len(changed),
                          "overlap_share": round(n_over / n_int, 3) if n_int else None}))
        return 0
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
