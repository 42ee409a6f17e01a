"""The report's claims, every one of the seed part by part, each decided by one rule on paired runs (issue 49).

A claim part compares a side A with a side B on this machine's own records: the per-round ratios A_r / B_r of the
rounds in which both ran (slurm/run-local runs the experiments a claim compares in one block of rounds, so that each
round holds a pair; records made before that are paired by repeat index and the row says so), their median and its
distribution-free interval with its true coverage (analysis/verdict.py), decided by analysis/verdict.py's one rule
with the margin `margin` gives (5%, or the machine's run-to-run drift where larger). The report's own ratio of its
published times stands beside ours; where our setting differs from the report's in what decides a claim (iteration
counts), the row says so beside the verdict. A part this machine cannot run (a GPU, more cores) is *not run*, with
what would decide it. Every sentence of a row is made from the records."""
import numpy as np

from analysis import radiosity_tables, table41, verdict
from analysis.records import paper_table

SCENE_NAMES = {1: "scene 1", 2: "scene 2", 3: "scene 3 (room3)", 4: "scene 4 (room2)"}


def margin():
    """The margin of the rule on this machine: 5%, or its measured drift from run to run where larger
    (analysis/reproducibility.py: the median change of its timed groups' medians between its committed runs)."""
    from analysis import reproducibility
    d = reproducibility.drift()
    return max(verdict.MARGIN, d) if d is not None else verdict.MARGIN


def part(claim, what, a, b, paper=None, expect="greater", value="time_s", note="", would=""):
    """A claim part: a / b paired, decided by the rule (expect "greater": a / b above 1; "less": below)."""
    p = verdict.paired(a, b, value)
    v = verdict.decide(p.low, p.high, expect, 1.0, margin())
    numbers = f"ours {p.text()}" if p.n else (would or "no pairs on this machine")
    if paper is not None and np.isfinite(paper):
        numbers += f"; the report's {paper:.3g}"
    return {"claim": claim, "part": what, "verdict": v, "numbers": numbers, "note": note, "ratio": p.ratio,
            "low": p.low, "high": p.high, "n": p.n, "coverage": p.coverage, "interleaved": p.interleaved,
            "expect": expect}


def _sel(df, **eq):
    if df is None or df.empty:
        return df
    out = df
    for col, v in eq.items():
        if col not in out:
            return out.iloc[0:0]
        out = out[out[col] == v]
    return out


def _ratio(table, scene, a, b):
    t = paper_table(table).set_index("scene")
    return t.loc[scene, a] / t.loc[scene, b] if scene in t.index else None


def bicgstab(preset):
    """Table 4.2: BiCG-STAB needs fewer iterations than Jacobi but more time, "in all cases": per scene the records
    hold, its iterations, its cost per iteration and its time over Jacobi's."""
    claim = "BiCG-STAB needs fewer iterations than Jacobi but more time, in all cases (Table 4.2)"
    df = radiosity_tables.solves("table42", preset)
    p = paper_table("table42").set_index("scene")
    out = []
    for s in sorted(set(df["scene_id"].dropna())) if not df.empty else []:
        j = _sel(df, scene_id=s, **{"params.method": "jacobi", "params.backend": "openmp"})
        b = _sel(df, scene_id=s, **{"params.method": "bicgstab", "params.backend": "openmp"})
        if j.empty or b.empty:
            continue
        j, b = j.assign(per_it=j["time_s"] / j["result.iterations"]), b.assign(per_it=b["time_s"] / b["result.iterations"])
        it_j, it_b = int(np.median(j["result.iterations"])), int(np.median(b["result.iterations"]))
        rep = p.loc[s] if s in p.index else None
        differs = ""
        if rep is not None and (it_j, it_b) != (int(rep.jacobi_iter), int(rep.bicgstab_iter)):
            differs = (f"our iterations (Jacobi {it_j}, BiCG-STAB {it_b}) are not the report's ({int(rep.jacobi_iter)}, "
                       f"{int(rep.bicgstab_iter)}): the time follows from the iterations and the cost of each")
        name = SCENE_NAMES.get(int(s), f"scene {int(s)}")
        out.append(part(claim, f"{name}: iterations, BiCG-STAB over Jacobi", b, j,
                        rep.bicgstab_iter / rep.jacobi_iter if rep is not None else None, "less", "result.iterations",
                        differs))
        out.append(part(claim, f"{name}: cost per iteration, BiCG-STAB over Jacobi", b, j,
                        (rep.bicgstab_s / rep.bicgstab_iter) / (rep.jacobi_s / rep.jacobi_iter) if rep is not None
                        else None, "greater", "per_it"))
        out.append(part(claim, f"{name}: time, BiCG-STAB over Jacobi", b, j,
                        rep.bicgstab_s / rep.jacobi_s if rep is not None else None, "greater", note=differs))
    return out or [part(claim, "all scenes", None, None, would="no Table 4.2 records of Jacobi and BiCG-STAB here")]


def openmp_speedup(preset):
    """Conclusion, Tables 4.3 and 4.4: OpenMP speeds up the serial and the original codes, per scene and layout."""
    claim = "OpenMP speeds up the serial and original codes (conclusion, Tables 4.3 and 4.4)"
    out = []
    for table, layout in (("table43", "AOS"), ("table44", "SOA")):
        df = radiosity_tables.solves(table, preset)
        for s in sorted(set(df["scene_id"].dropna())) if not df.empty else []:
            omp = _sel(df, scene_id=s, column="openmp")
            for other in ("serial", "original"):  # each table's own Original runs (issue 50)
                t = _sel(df, scene_id=s, column=other)
                if len(omp) and len(t):
                    out.append(part(claim, f"{SCENE_NAMES.get(int(s))}, {layout}: {other} over OpenMP", t, omp,
                                    _ratio(table, s, other, "openmp")))
    return out or [part(claim, "serial and original over OpenMP", None, None,
                        would="no Table 4.3 or 4.4 records of OpenMP beside serial here")]


def aos_openmp(preset):
    """Abstract, §4.4: AOS with OpenMP is the best layout: SOA's OpenMP time over AOS's, per scene."""
    claim = "AOS with OpenMP is the best layout (abstract, §4.4)"
    aos, soa = radiosity_tables.solves("table43", preset), radiosity_tables.solves("table44", preset)
    out = []
    scenes = sorted(set(aos["scene_id"].dropna()) & set(soa["scene_id"].dropna())) if not (aos.empty or soa.empty) else []
    for s in scenes:
        a, o = _sel(aos, scene_id=s, column="openmp"), _sel(soa, scene_id=s, column="openmp")
        if len(a) and len(o):
            p43, p44 = paper_table("table43").set_index("scene"), paper_table("table44").set_index("scene")
            out.append(part(claim, f"{SCENE_NAMES.get(int(s))}: SOA OpenMP over AOS OpenMP", o, a,
                            p44.loc[s, "openmp"] / p43.loc[s, "openmp"] if s in p43.index else None))
    return out or [part(claim, "SOA over AOS, OpenMP", None, None,
                        would="no Table 4.3 and 4.4 OpenMP records here")]


def poisson_scaling(preset):
    """Table 4.1, §4.1: more MPI processes reduce the run time; 4 to 8 processes gain little."""
    claim = "Poisson CG gets faster with more MPI processes p; 4 to 8 gain little (Table 4.1, §4.1)"
    df, _ = table41.ours(preset)
    plain = df[~df["column"].str.startswith(table41.MG)] if not df.empty else df
    paper = paper_table("table41").set_index("n")
    out = []
    ps = sorted(int(c[1:]) for c in set(plain["column"]) if c.startswith("p") and c[1:].isdigit()) if len(plain) else []
    for n in sorted(set(plain["params.n"])) if len(plain) else []:
        one = _sel(plain, **{"params.n": n, "column": "p1"})
        for q in (q for q in ps if q > 1):
            t = _sel(plain, **{"params.n": n, "column": f"p{q}"})
            if len(one) and len(t):
                ref = paper.loc[n, "p1"] / paper.loc[n, f"p{q}"] if n in paper.index else None
                out.append(part(claim, f"N = {int(n)}: p1 over p{q}", one, t, ref))
    cores = int(df["provenance.cpus_online"].max()) if len(df) and "provenance.cpus_online" in df else None
    if not any(q >= 8 for q in ps):
        out.append(part(claim, "p4 over p8 (the report: little gain)", None, None,
                        paper.loc[1024, "p4"] / paper.loc[1024, "p8"],
                        would=f"not run: needs 8 cores{f' (this machine has {cores})' if cores else ''}; decided by "
                              "Table 4.1's p4 and p8 columns paired per N, expect near 1"))
    return out or [part(claim, "p1 over p > 1", None, None, would="no Table 4.1 MPI records of p = 1 and p > 1")]


def _gpu_not_run(claim, what, how):
    return part(claim, what, None, None, would=f"not run: needs a GPU (make gpu-kit, docs/running.md); decided by {how}")


def _runs(df, **eq):
    return _sel(df, **eq) if df is not None and not df.empty else df


def gpu_poisson(preset):
    """Table 4.1, §4.2: the GPU beats the CPU; our own kernels (cuBLAS 1) beat all-cuBLAS (cuBLAS 2); for the
    smallest N the CPU beats the GPU."""
    df, _ = table41.ours(preset)
    plain = df[~df["column"].str.startswith(table41.MG)] if not df.empty else df
    paper = paper_table("table41").set_index("n")
    out = []
    claim = "Our own kernels (cuBLAS 1) beat all-cuBLAS (cuBLAS 2) (§3.2, Table 4.1)"
    got = [part(claim, f"N = {int(n)}: cuBLAS 2 over cuBLAS 1", _runs(plain, **{"params.n": n, "column": "cublas2"}),
                _runs(plain, **{"params.n": n, "column": "cublas1"}),
                paper.loc[n, "cublas2"] / paper.loc[n, "cublas1"] if n in paper.index else None)
           for n in sorted(set(plain["params.n"])) if len(plain)] if len(plain) else []
    got = [g for g in got if g["n"]]
    out += got or [_gpu_not_run(claim, "cuBLAS 2 over cuBLAS 1", "Table 4.1's cublas1 and cublas2 paired per N")]
    claim = "The GPU outperforms the CPU, except at the smallest N (§4.2, Table 4.1)"
    got = []
    ns = sorted(set(plain["params.n"])) if len(plain) else []
    for n in ns:
        at = plain[plain["params.n"] == n]
        g = table41.on_gpu(at)
        c = sorted(set(at["column"]) - set(g))
        if g and c:
            best_g = min(g, key=lambda x: at[at["column"] == x]["time_s"].median())
            best_c = min(c, key=lambda x: at[at["column"] == x]["time_s"].median())
            smallest = n == ns[0]
            ref = paper.loc[n, "p16"] / min(paper.loc[n, "cublas1"], paper.loc[n, "cublas2"]) if n in paper.index else None
            got.append(part(claim, f"N = {int(n)}: best CPU ({best_c}) over best GPU ({best_g})"
                            + (" (the smallest N: the CPU expected faster)" if smallest else ""),
                            at[at["column"] == best_c], at[at["column"] == best_g], ref,
                            "less" if smallest else "greater"))
    out += got or [_gpu_not_run(claim, "best CPU over best GPU, per N", "Table 4.1's CPU and GPU columns paired per N "
                                "(above 1 for large N, below 1 for the smallest)")]
    return out


def _table_gpu(table, claim, what, expect_of):
    def fn(preset):
        df = radiosity_tables.solves(table, preset)
        out = []
        for s in sorted(set(df["scene_id"].dropna())) if not df.empty else []:
            g, o = _sel(df, scene_id=s, column="cuda"), _sel(df, scene_id=s, column="openmp")
            if len(g) and len(o):
                out.append(part(claim, f"{SCENE_NAMES.get(int(s))}: {what}", g, o, _ratio(table, s, "cuda", "openmp"),
                                expect_of(int(s))))
        return out or [_gpu_not_run(claim, what, f"{table}'s cuda and openmp columns paired per scene")]
    return fn


gpu_aos = _table_gpu("table43", "OpenMP beats CUDA with AOS, except on scene 1 (§4.4, Table 4.3)", "CUDA over OpenMP",
                     lambda s: "less" if s == 1 else "greater")
gpu_soa = _table_gpu("table44", "CUDA with cuBLAS (SOA) beats OpenMP on the larger scenes, not the small (§4.5, "
                     "Table 4.4)", "CUDA over OpenMP", lambda s: "less" if s >= 3 else "greater")


def gpu_layouts(preset):
    """§4.5: our SOA version for CUDA (cuBLAS) is faster than the AOS version for CUDA (own kernels)."""
    claim = "CUDA with SOA (cuBLAS) is faster than CUDA with AOS (§4.5)"
    aos, soa = radiosity_tables.solves("table43", preset), radiosity_tables.solves("table44", preset)
    out = []
    scenes = sorted(set(aos["scene_id"].dropna()) & set(soa["scene_id"].dropna())) if not (aos.empty or soa.empty) else []
    for s in scenes:
        a, o = _sel(aos, scene_id=s, column="cuda"), _sel(soa, scene_id=s, column="cuda")
        if len(a) and len(o):
            p43, p44 = paper_table("table43").set_index("scene"), paper_table("table44").set_index("scene")
            out.append(part(claim, f"{SCENE_NAMES.get(int(s))}: CUDA AOS over CUDA SOA", a, o,
                            p43.loc[s, "cuda"] / p44.loc[s, "cuda"] if s in p43.index else None))
    return out or [_gpu_not_run(claim, "CUDA AOS over CUDA SOA", "Table 4.3's cuda and Table 4.4's cuda paired per scene")]


def hybrid(preset):
    """Table 4.5, §4.6: a share of rows on each device improves on d = 0 and d = 1; the hybrid does not beat either
    device alone (the report)."""
    claim = "The hybrid improves on d = 0 and d = 1 at its best d (§4.6, Table 4.5)"
    df = radiosity_tables.solves("table45", preset)
    if df.empty:
        return [_gpu_not_run(claim, "d = 0 and d = 1 over the best d", "Table 4.5's sweep paired per round")]
    d = df["params.distribution"].round(3)
    meds = df.groupby(d)["time_s"].median()
    best = meds.drop([x for x in (0.0, 1.0) if x in meds.index]).idxmin() if len(meds) > 2 else None
    k20 = paper_table("table45").set_index("distribution")["runtime_s"]
    out = []
    for e in (0.0, 1.0):
        if best is not None and (d == e).any():
            ref = k20.get(e) / k20.drop([0.0, 1.0]).min() if e in k20.index else None
            out.append(part(claim, f"d = {e:g} over the best d ({best:g})", df[d == e], df[d == best], ref))
    return out or [_gpu_not_run(claim, "d = 0 and d = 1 over the best d", "Table 4.5's sweep paired per round")]


CLAIMS = (bicgstab, openmp_speedup, aos_openmp, poisson_scaling, gpu_poisson, gpu_aos, gpu_soa, gpu_layouts, hybrid)


def all_claims(preset):
    """Every claim's parts, in order: dicts with claim, part, verdict, numbers, note (and ratio, low, high, n,
    coverage, interleaved, expect)."""
    return [r for fn in CLAIMS for r in fn(preset)]
