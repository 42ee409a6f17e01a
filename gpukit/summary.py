"""The kit's summary table (summary.md in its archive): what the GPU node measured, beside the report's K20 and
the GPU's own triad, and the steps run, skipped and failed. Standard library only (it runs on the node).

A measurement counts only when its run converged (or ran its fixed steps) and agreed with the float64 check."""
import csv
import json
from pathlib import Path


def load(results, garbled=None, state=False):
    """{experiment: [record]} (or, with state, {experiment: [state line]}: the state files beside the records); a
    line that is no JSON object is left out and named in `garbled` (a list)."""
    recs = {}
    for f in sorted(Path(results).glob("*/*.jsonl")):
        if f.name.endswith(".state.jsonl") != state:
            continue
        recs[f.parent.name] = []
        for k, line in enumerate(f.read_text(errors="replace").splitlines(), 1):
            try:
                rec = json.loads(line)
            except ValueError:
                rec = None
            if isinstance(rec, dict):
                recs[f.parent.name].append(rec)
            elif line.strip() and garbled is not None:
                garbled.append(f"{f.parent.name}/{f.name}:{k}: {line[:100]!r}")
    return recs


def paper(folder, name):
    p = Path(folder) / f"{name}.csv"
    if not p.exists():
        return []
    return list(csv.DictReader(l for l in p.read_text().splitlines() if not l.startswith("#")))


def counts(r):
    res = r.get("result", {})
    if r.get("app") == "poisson":
        return res.get("converged") is True
    return res.get("status") in ("converged", "steps_done") and (r.get("verify") or {}).get("agreed") is True


def scene_no(path):
    name = Path(str(path)).name
    return {"scene1.xml": 1, "scene2.xml": 2, "room3.xml": 3, "room2.xml": 4}.get(name)


def precond(r):
    return r.get("params", {}).get("precond") or "none"


def fmt(x, spec=".4g"):
    return "-" if x is None else format(x, spec)


def median(xs):
    xs = sorted(x for x in xs if isinstance(x, (int, float)))
    n = len(xs)
    return None if n == 0 else xs[n // 2] if n % 2 else 0.5 * (xs[n // 2 - 1] + xs[n // 2])


def per_case(rows):
    """One row per case (HPCGI_CASE) in the order first seen: a representative record with the medians of its runs
    that count ("times_s.solve" and "perf.bandwidth_GBps" replaced), their count n, and whether every run counted."""
    groups = {}
    for r in rows:
        case = ((r.get("provenance") or {}).get("env") or {}).get("HPCGI_CASE")
        groups.setdefault((case, json.dumps(r.get("params"), sort_keys=True)), []).append(r)
    out = []
    for runs in groups.values():
        good = [r for r in runs if counts(r)]
        rep = dict(good[-1] if good else runs[-1])
        rep["times_s"] = dict(rep.get("times_s") or {}, solve=median([(r.get("times_s") or {}).get("solve")
                                                                       for r in good]))
        rep["perf"] = dict(rep.get("perf") or {}, bandwidth_GBps=median([(r.get("perf") or {}).get("bandwidth_GBps")
                                                                         for r in good]))
        out.append((rep, len(good), len(good) == len(runs)))
    return out


def write(results, paper_dir, driver=None):
    garbled = []
    recs = load(results, garbled)
    out = ["# GPU kit summary", ""]
    if driver is not None:
        out += node_lines(driver)
    stream = [r for r in recs.get("gpu-stream", []) if r.get("result", {}).get("valid")]
    triad = stream[-1]["perf"]["triad_GBps"] if stream else None
    if stream:
        s = stream[-1]
        info = {k: md(v) for k, v in s["backend_info"].items()}
        out += [f"GPU: {info.get('gpu')} (driver {info.get('cuda_driver')}, runtime {info.get('cuda_runtime')}, SM "
                f"clock {info.get('gpu_clock_MHz')} MHz, memory clock {info.get('gpu_memory_clock_MHz')} MHz)", "",
                f"Bandwidth limit (bin/stream --device gpu, best of {s['params']['trials']}): triad "
                f"{s['perf']['triad_GBps']:.0f} GB/s, read-only sweep {s['perf']['read_GBps']:.0f} GB/s", ""]
    else:
        out += ["No GPU triad was measured: the fractions of it below are left out.", ""]

    def frac(r):
        bw = r.get("perf", {}).get("bandwidth_GBps")
        return None if bw is None or not triad else bw / triad

    out += gpu_state_lines(load(results, state=True))
    out += table41_lines(recs, paper_dir, frac)
    # Tables 4.3, 4.4 and their 32-step runs
    for exp, title, col in (("table43", "Table 4.3 (AOS, Jacobi to 1e-6)", "cuda"),
                            ("table44", "Table 4.4 (SOA, Jacobi to 1e-6)", "cuda"),
                            ("table43-steps32", "Table 4.3, RRV's 32 fixed steps", None)):
        rows = recs.get(exp, [])
        if not rows:
            continue
        ref = {int(row["scene"]): row for row in paper(paper_dir, exp.split("-")[0])}
        out += [f"## {title}", "", "| scene | backend | steps | median solve s | n | GB/s | of triad | K20 s (report) | "
                "all count |", "|---|---|---|---|---|---|---|---|---|"]
        for r, n, every in per_case(rows):
            p = r["params"]
            k = scene_no(p.get("scene"))
            be = p["backend"] + (" --fused" if p.get("fused") else "")
            k20s = ref.get(k, {}).get(col) if col and p["backend"] in ("cuda", "cublas") else None
            out.append(f"| {k} | {md(be)} | {r['result'].get('iterations')} | {fmt(r['times_s'].get('solve'))} | {n} | "
                       f"{fmt(r['perf'].get('bandwidth_GBps'), '.0f')} | {fmt(frac(r), '.0%')} | {md(k20s or '-')} | "
                       f"{'yes' if every else 'NO'} |")
        out.append("")
    # Table 4.5
    k20 = {float(row["distribution"]): row["runtime_s"] for row in paper(paper_dir, "table45")}
    plain = {r["params"]["distribution"]: r for r in recs.get("table45", []) if counts(r)}
    over = {r["params"]["distribution"]: r for r in recs.get("table45-overlap", []) if counts(r)}
    if plain or over:
        out += ["## Table 4.5 (scene 4, hybrid Jacobi to 1e-6)", "",
                "| d | solve s | with --overlap | K20 node s (report) |", "|---|---|---|---|"]
        for dd in sorted(set(plain) | set(over)):
            t = lambda m: fmt(m[dd]["times_s"].get("solve")) if dd in m else "-"
            out.append(f"| {dd:.1f} | {t(plain)} | {t(over)} | {md(k20.get(dd, '-'))} |")
        out.append("")
        for name, m in (("as the report", plain), ("with --overlap", over)):
            if 0.0 in m and 1.0 in m and len(m) > 2:
                best = min(m, key=lambda x: m[x]["times_s"]["solve"])
                tb = m[best]["times_s"]["solve"]
                beats = tb < m[0.0]["times_s"]["solve"] and tb < m[1.0]["times_s"]["solve"]
                out.append(f"- hybrid {name}: fastest at d = {best:.1f} ({tb:.4g} s); it "
                           f"{'beats' if beats else 'does not beat'} both d = 0 and d = 1 (the report: no)")
        out.append("")
    out += speed_targets(recs, frac)
    if garbled:
        out += ["## Garbled records", "", f"{len(garbled)} record lines are no JSON object: left out of the tables "
                "above (and of the archive's records: logs/garbled-records.txt)", ""]
        out += [f"- {md(g)}" for g in garbled] + [""]
    if driver is not None:
        out += step_lines(driver)
    return "\n".join(out) + "\n"


def md(text):
    """Text from files or programs made inert in markdown: no table cell broken, no code span, no HTML."""
    return (str(text).replace("\\", "\\\\").replace("|", "\\|").replace("`", "\\`").replace("*", "\\*")
            .replace("_", "\\_").replace("<", "&lt;").replace(">", "&gt;").replace("\n", " "))


def speed_targets(recs, frac):
    """Issue 18's targets, each read from the runs it names: Jacobi's 32 steps on scene 4 (cuda, float32 F dense;
    and float16 F, compressed), Poisson plain CG at N = 8192 on cuda; MG-PCG beside it, labelled, with no target."""
    out = ["## Speed targets", ""]
    scene4 = lambda exp: [r for r in recs.get(exp, []) if scene_no(r["params"].get("scene")) == 4
                          and r["params"]["backend"] == "cuda" and counts(r)]
    for exp, what, target in (("table43-steps32", "float32 F, dense", 0.012),
                              ("gpu-float16", "float16 F, compressed", 0.006)):
        j = scene4(exp)
        if not j:
            out.append(f"- Jacobi, scene 4, 32 steps, cuda, {what}: not measured")
            continue
        t, f = j[-1]["times_s"]["solve"], frac(j[-1])
        out.append(f"- Jacobi, scene 4, 32 steps, cuda, {what}: {t * 1e3:.2f} ms (target <= {target * 1e3:.0f} ms "
                   f"on an H200; report 1.185 s on a K20): {'holds' if t <= target else 'does not hold'}"
                   + (f"; {fmt(f, '.0%')} of the triad (target >= 85%): "
                      f"{'holds' if f is not None and f >= 0.85 else 'does not hold'}" if target == 0.012 else ""))
    n8192 = lambda pc: [r for r in recs.get("table41", []) if r["params"].get("n") == 8192
                        and r["params"]["backend"] == "cuda" and precond(r) == pc and counts(r)]
    cg, mg = n8192("none"), n8192("mg")
    if cg:
        t = cg[-1]["times_s"]["solve"]
        out.append(f"- Poisson plain CG N = 8192, cuda: {t:.2f} s, {cg[-1]['result'].get('iterations')} iterations "
                   f"(target <= 15 s on an H200; report 747 s with cuBLAS 1): {'holds' if t <= 15 else 'does not hold'}")
    else:
        out.append("- Poisson plain CG N = 8192, cuda: not measured")
    if mg:
        out.append(f"- Poisson MG-PCG N = 8192, cuda (no target; beside plain CG): {mg[-1]['times_s']['solve']:.2f} s, "
                   f"{mg[-1]['result'].get('iterations')} iterations")
    else:
        out.append("- Poisson MG-PCG N = 8192, cuda (no target; beside plain CG): not measured")
    return out + [""]


def gpu_state_lines(states):
    """The GPU's state beside the recorded runs (gpukit/gpu_state.py): its SM clock, temperature and power before and
    after them, the clock-limiting reasons seen, and the runs flagged disturbed."""
    lines = [s for v in states.values() for s in v]
    samples = [(w, s[w]) for s in lines for w in ("gpu_before", "gpu_after") if isinstance(s.get(w), dict)]
    out = ["## The GPU beside the runs", ""]
    if not samples:
        why = next((s.get("gpu_state") for s in lines if s.get("gpu_state")), None)
        return out + [f"Not sampled{': ' + md(why) if why else ''}.", ""]
    span = lambda key, when: [v[key] for w, v in samples if w == when and isinstance(v.get(key), (int, float))]
    rng = lambda xs: f"{min(xs):.0f}-{max(xs):.0f}" if xs else "-"
    out += ["| | SM clock MHz | memory clock MHz | temperature C | power W |", "|---|---|---|---|---|"]
    for when in ("gpu_before", "gpu_after"):
        out.append(f"| {when.split('_')[1]} the runs | {rng(span('sm_MHz', when))} | {rng(span('mem_MHz', when))} | "
                   f"{rng(span('temperature_C', when))} | {rng(span('power_W', when))} |")
    seen = sorted({v.get("reasons_text") for _, v in samples if v.get("reasons_text")})
    bad = [s for s in lines if s.get("disturbed")]
    out += ["", f"- {len(lines)} runs sampled before and after; clock reasons seen: {md(', '.join(seen) or 'none')}",
            f"- {len(bad)} runs flagged disturbed (a thermal or hardware slowdown, or the power brake), left out of the "
            "tables at home" + (": " + md("; ".join(f"{s['case']} repeat {s['repeat']}: {s.get('reason')}"
                                                    for s in bad[:10])) if bad else ""), ""]
    return out


def node_lines(d):
    """What the probes found, and whether the driver died."""
    out = ["What the node offered (the kit's probes):", ""] + [f"- {md(l)}" for l in d.found] + [""]
    if d.died:
        out += [f"**The driver stopped before its end: {md(d.died)}** (logs/driver-traceback.txt). The steps it had "
                "not reached are not listed below; what it recorded before is.", ""]
    return out


def step_lines(d):
    """Every step with the plan's estimate beside its measured time and what became of it."""
    n = lambda r: sum(1 for o in d.outcomes if o.result == r)
    out = ["## Steps", "", f"- run and passed: {n('ok')}", f"- failed: {n('FAILED')}",
           f"- skipped (time, a library or a tool the node lacks): {n('skipped')}", f"- measured pace: "
           f"{d.pace():.2f} s per estimated second", "",
           "| # | step | group | estimated s | measured s | outcome | why |", "|---|---|---|---|---|---|---|"]
    for k, o in enumerate(d.outcomes, 1):
        out.append(f"| {k} | {md(o.name)} | {md(o.group)} | {o.estimate_s} | {fmt(o.measured_s, '.1f')} | {o.result} "
                   f"| {md(o.why)} |")
    return out + [""]


def table41_lines(recs, paper_dir, frac):
    """Table 4.1's GPU columns: each run with its preconditioner; the K20's time beside plain CG only."""
    out = []
    k20 = {int(row["n"]): row for row in paper(paper_dir, "table41")}
    rows = [r for r in recs.get("table41", []) if r.get("app") == "poisson"]
    if rows:
        out += ["## Table 4.1, GPU columns (Poisson CG to 1e-6; the report's K20 ran plain CG only)", "",
                "| backend | precond | N | iterations | median solve s | n | GB/s | of triad | K20 s (report) | K20 / ours | "
                "all count |", "|---|---|---|---|---|---|---|---|---|---|---|"]
        for r, cnt, every in sorted(per_case(rows), key=lambda x: (x[0]["params"]["n"], precond(x[0]),
                                                                    x[0]["params"]["backend"])):
            n, be, t = r["params"]["n"], r["params"]["backend"], r["times_s"].get("solve")
            ref = k20.get(n, {}).get(be) if precond(r) == "none" else None
            ref = float(ref) if ref not in (None, "") else None
            out.append(f"| {md(be)} | {md(precond(r))} | {n} | {r['result'].get('iterations')} | {fmt(t)} | {cnt} | "
                       f"{fmt(r['perf'].get('bandwidth_GBps'), '.0f')} | {fmt(frac(r), '.0%')} | {fmt(ref)} | "
                       f"{fmt(ref / t if ref and t else None, '.1f')} | {'yes' if every else 'NO'} |")
        out.append("")
    return out
