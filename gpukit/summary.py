"""The kit's summary table (summary.md in its archive): what the GPU node measured, beside the report's K20 and
the GPU's own triad, and the steps run, skipped and failed. Standard library only (it runs on the node).

A measurement counts only when its run converged (or ran its fixed steps) and agreed with the float64 check."""
import csv
import json
from pathlib import Path


def load(results):
    recs = {}
    for f in sorted(Path(results).glob("*/*.jsonl")):
        recs[f.parent.name] = [json.loads(l) for l in f.read_text().splitlines() if l.strip()]
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


def fmt(x, spec=".4g"):
    return "-" if x is None else format(x, spec)


def write(results, paper_dir, driver=None):
    recs = load(results)
    out = ["# GPU kit summary", ""]
    stream = [r for r in recs.get("gpu-stream", []) if r.get("result", {}).get("valid")]
    triad = stream[-1]["perf"]["triad_GBps"] if stream else None
    if stream:
        s = stream[-1]
        out += [f"GPU: {s['backend_info'].get('gpu')} (driver {s['backend_info'].get('cuda_driver')}, runtime "
                f"{s['backend_info'].get('cuda_runtime')}, SM clock {s['backend_info'].get('gpu_clock_MHz')} MHz, "
                f"memory clock {s['backend_info'].get('gpu_memory_clock_MHz')} MHz)", "",
                f"Bandwidth limit (bin/stream --device gpu, best of {s['params']['trials']}): triad "
                f"{s['perf']['triad_GBps']:.0f} GB/s, read-only sweep {s['perf']['read_GBps']:.0f} GB/s", ""]
    else:
        out += ["No GPU triad was measured: the fractions of it below are left out.", ""]

    def frac(r):
        bw = r.get("perf", {}).get("bandwidth_GBps")
        return None if bw is None or not triad else bw / triad

    # Table 4.1
    k20 = {int(row["n"]): row for row in paper(paper_dir, "table41")}
    rows = [r for r in recs.get("table41", []) if r.get("app") == "poisson"]
    if rows:
        out += ["## Table 4.1, GPU columns (Poisson CG to 1e-6)", "",
                "| backend | N | iterations | solve s | GB/s | of triad | K20 s (report) | K20 / ours | counts |",
                "|---|---|---|---|---|---|---|---|---|"]
        for r in sorted(rows, key=lambda r: (r["params"]["n"], r["params"]["backend"])):
            n, be, t = r["params"]["n"], r["params"]["backend"], r["times_s"].get("solve")
            ref = k20.get(n, {}).get(be)
            ref = float(ref) if ref not in (None, "") else None
            out.append(f"| {be} | {n} | {r['result'].get('iterations')} | {fmt(t)} | "
                       f"{fmt(r['perf'].get('bandwidth_GBps'), '.0f')} | {fmt(frac(r), '.0%')} | {fmt(ref)} | "
                       f"{fmt(ref / t if ref and t else None, '.1f')} | {'yes' if counts(r) else 'NO'} |")
        out.append("")
    # Tables 4.3, 4.4 and their 32-step runs
    for exp, title, col in (("table43", "Table 4.3 (AOS, Jacobi to 1e-6)", "cuda"),
                            ("table44", "Table 4.4 (SOA, Jacobi to 1e-6)", "cuda"),
                            ("table43-steps32", "Table 4.3, RRV's 32 fixed steps", None),
                            ("table44-steps32", "Table 4.4, RRV's 32 fixed steps", None)):
        rows = recs.get(exp, [])
        if not rows:
            continue
        ref = {int(row["scene"]): row for row in paper(paper_dir, exp.split("-")[0])}
        out += [f"## {title}", "", "| scene | backend | steps | solve s | GB/s | of triad | K20 s (report) | counts |",
                "|---|---|---|---|---|---|---|---|"]
        for r in rows:
            p = r["params"]
            k = scene_no(p.get("scene"))
            be = p["backend"] + (" --fused" if p.get("fused") else "")
            k20s = ref.get(k, {}).get(col) if col else None
            out.append(f"| {k} | {be} | {r['result'].get('iterations')} | {fmt(r['times_s'].get('solve'))} | "
                       f"{fmt(r['perf'].get('bandwidth_GBps'), '.0f')} | {fmt(frac(r), '.0%')} | {k20s or '-'} | "
                       f"{'yes' if counts(r) else 'NO'} |")
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
            out.append(f"| {dd:.1f} | {t(plain)} | {t(over)} | {k20.get(dd, '-')} |")
        out.append("")
        for name, m in (("as the report", plain), ("with --overlap", over)):
            if 0.0 in m and 1.0 in m and len(m) > 2:
                best = min(m, key=lambda x: m[x]["times_s"]["solve"])
                tb = m[best]["times_s"]["solve"]
                beats = tb < m[0.0]["times_s"]["solve"] and tb < m[1.0]["times_s"]["solve"]
                out.append(f"- hybrid {name}: fastest at d = {best:.1f} ({tb:.4g} s); it "
                           f"{'beats' if beats else 'does not beat'} both d = 0 and d = 1 (the report: no)")
        out.append("")
    # The speed targets of issue 18
    out += ["## Speed targets", ""]
    j = [r for r in recs.get("table43-steps32", []) if scene_no(r["params"].get("scene")) == 4
         and r["params"]["backend"] == "cuda" and counts(r)]
    if j:
        r = j[-1]
        t = r["times_s"]["solve"]
        f = frac(r)
        out.append(f"- Jacobi, scene 4, 32 steps, cuda: {t * 1e3:.2f} ms (target <= 12 ms on an H200; report 1.185 s "
                   f"on a K20): {'holds' if t <= 0.012 else 'does not hold'}; {fmt(f, '.0%')} of the triad "
                   f"(target >= 85%): {'holds' if f is not None and f >= 0.85 else 'does not hold'}")
    else:
        out.append("- Jacobi, scene 4, 32 steps, cuda: not measured")
    out.append("- float16 F on the GPU: not measured (the GPU backends read float32 F only)")
    cg = [r for r in recs.get("table41", []) if r["params"].get("n") == 8192 and r["params"]["backend"] == "cuda"
          and counts(r)]
    if cg:
        t = cg[-1]["times_s"]["solve"]
        out.append(f"- Poisson CG N = 8192, cuda: {t:.2f} s (target <= 15 s on an H200; report 747 s with cuBLAS 1): "
                   f"{'holds' if t <= 15 else 'does not hold'}")
    else:
        out.append("- Poisson CG N = 8192, cuda: not measured")
    out.append("")
    if driver is not None:
        out += ["## Steps", "", f"- run and passed: {len(driver.done)}",
                f"- skipped (budget or missing tool): {len(driver.skipped)}"]
        out += [f"  - {s}" for s in driver.skipped]
        out += [f"- failed: {len(driver.failed)}"] + [f"  - {s}" for s in driver.failed]
        out.append("")
    return "\n".join(out) + "\n"
