"""python -m analysis.bench [PRESET]: the table of `make bench` from the bench-* records of one machine (the host of
the newest bandwidth record): medians over repeats of our time per iteration, the bandwidth it implies as a
fraction of the triad bandwidth measured next to it (slurm/bench measures the limit before every case: on a shared
VM it drifts with the neighbours), and the peers' time over ours; then the targets of issue 7, met or not. Prints
the table and writes $RESULTS/<machine>/tables/bench_PRESET.md. The bench-mg records (issue 19) make a second table: MG-PCG
to 1e-6 against PETSc's CG with hypre's BoomerAMG and with GAMG (bench/petsc_poisson.py), time to solution and
error; plain CG per iteration against PETSc's CG, whose iterations must equal ours."""
import sys

import pandas as pd

from analysis import consistency
from analysis.escape import md, md_table
from analysis.bench_records import Interval, ci_of, limit_next_to, median_of, on_host, target
from analysis.bench_sparse import sparse_rows
from analysis.records import load, tables_dir

# Issue 7's targets on the CPU: CG at >= 80% of the triad bandwidth and >= 8x SciPy; a Jacobi step within 1.15x
# of 4·N² bytes at the triad bandwidth, >= 2.5x the best NumPy way, and >= 1.7x faster with F in float16.
CG_FRACTION, CG_VS_SCIPY, JACOBI_SLACK, JACOBI_VS_NUMPY, HALF_VS_FLOAT = 0.80, 8.0, 1.15, 2.5, 1.7
# Issue 19's: MG-PCG's time to 1e-6 at N = 2048 and 4096 at most 0.5x PETSc CG + BoomerAMG's and below PETSc CG +
# GAMG's; plain CG per iteration >= 3x PETSc's CG; N = 8192 in at most 10 s.
MG_VS_HYPRE, CG_VS_PETSC, MG_8192_S = 0.5, 3.0, 10.0
# Issue 37's: at N = 8191 or 8192, FMG's solve <= 0.5 s and its whole process <= 1.0 s, both faster than the DST
# solver's; its setup <= 0.35 s, or <= 1.2x the time to write 3 vectors of N² at the triad bandwidth next to it.
FMG_SOLVE_S, FMG_PROCESS_S, FMG_SETUP_S, SETUP_VS_WRITE = 0.5, 1.0, 0.35, 1.2
PETSC = {"none": "PETSc CG (AIJ 5-point)", "hypre": "PETSc CG + hypre BoomerAMG", "gamg": "PETSc CG + GAMG",
         "mg": "PETSc CG + geometric MG (DMDA, Galerkin)"}


def _problem(out, stream, title, entries):
    """One problem's rows into out. entries: (solver, records, bytes per iteration or None, ours?); time / ours is
    against our fastest. Returns our fastest as (solver, records, bytes, ours, time, triad next to it) and the
    peers' times."""
    entries = [(name, recs, b, mine, median_of(recs, "times_s.per_iteration"), limit_next_to(stream, recs))
               for name, recs, b, mine in entries if len(recs)]
    ours = [e for e in entries if e[3]]
    if not ours:
        return None, {}
    fastest = min(ours, key=lambda e: e[4])
    for k, (name, recs, b, mine, t, triad) in enumerate(entries):
        gbps = b / t / 1e9 if b else None
        out.append({"problem": title if k == 0 else "", "solver": ("ours: " if mine else "") + name,
                    "ms per iteration": 1e3 * t, "95% interval (ms)": ci_of(recs, "times_s.per_iteration", 1e3),
                    "GB/s": gbps, "triad next to it": triad if mine and b else None,
                    "of triad": gbps / triad if mine and b else None, "time / ours": t / fastest[4],
                    "repeats": len(recs)})
    return fastest, {name: recs for name, recs, _, mine, _, _ in entries if not mine}


def faster(peer, ours, col="times_s.per_iteration"):
    """peer / ours of col: paired per round where they share rounds, else the ratio of the medians (n=1)."""
    iv = Interval.paired(peer, ours, col)
    if iv is None:
        x = median_of(peer, col) / median_of(ours, col)
        iv = Interval(x, x, x, 1, "ratio of medians, not paired")
    return iv


def _cg_rows(preset, host, stream, out, targets):
    """Poisson CG per N (bench-cg): our variants against SciPy's CG; issue 7's CG targets at N = 2048."""
    cg = on_host(load("bench-cg", preset), host)
    if len(cg):
        mine, peer = cg[cg["app"] == "poisson"], cg[cg["app"] == "peer"]
        for n in sorted(mine["params.n"].unique()):
            sp = peer[peer["params.n"] == n]
            entries = []
            for v in ("onesweep", "classic"):
                o = mine[(mine["params.n"] == n) & (mine["params.variant"] == v)]
                if len(o):
                    entries.append((f"openmp {v}, {int(o['perf.vectors_per_iteration'].iloc[0])} vectors", o,
                                     float(o["perf.bytes_per_iteration"].iloc[0]), True))
            entries.append(("SciPy sparse.linalg.cg (CSR)", sp, None, False))
            its = int(mine[mine["params.n"] == n]["result.iterations"].median())
            sp_its = f", SciPy {int(sp['result.iterations'].median())}" if len(sp) else ""
            fastest, peers = _problem(out, stream, f"Poisson CG double N={n} ({its} it.{sp_its})", entries)
            if n == 2048 and fastest:
                frac = Interval.of([fastest[2] / t / 1e9 / fastest[5] for t in fastest[1]["times_s.per_iteration"]])
                targets.append(target(f"CG N=2048 ({fastest[0]}): the share of the triad bandwidth next to it "
                                      f"({fastest[5]:.1f} GB/s)", frac, CG_FRACTION, "greater"))
                for name, recs in peers.items():
                    targets.append(target(f"CG N=2048: times faster per iteration than {name}",
                                          faster(recs, fastest[1]), CG_VS_SCIPY, "greater", "x"))


def _jacobi_rows(preset, host, stream, out, targets):
    """A Jacobi step on room3 (bench-jacobi): our layouts against NumPy's products, F in 16 bits against float32;
    issue 7's Jacobi targets."""
    jac = on_host(load("bench-jacobi", preset), host)
    if len(jac):
        mine, peer = jac[jac["app"] == "radiosity"], jac[jac["app"] == "peer"]
        prec = mine["params.ff_precision"] if "params.ff_precision" in mine else pd.Series("float32", mine.index)
        mine, half = mine[prec == "float32"], mine[prec != "float32"]
        n = int(jac["params.patches"].iloc[0])
        nbytes = float(mine["perf.matrix_bytes"].iloc[0]) if len(mine) else 4.0 * n * n
        entries = [(f"openmp float {l.upper()}, one pass over F", mine[mine["params.layout"] == l], nbytes, True)
                   for l in ("aos", "soa")]
        for l in ("aos", "soa"):
            x = mine[mine["params.layout"] == l]
            consistency.quote("room3.xml: one Jacobi step, OpenMP, float (ms)",
                              f"make bench ({preset}), Jacobi step, openmp float {l.upper()}",
                              1e3 * x["times_s.per_iteration"], x)
        entries += [("NumPy F @ B (sgemm, 3 columns)", peer[peer["params.way"] == "gemm"], 4.0 * n * n, False),
                    ("NumPy 3 x F @ b (sgemv)", peer[peer["params.way"] == "gemv"], 3 * 4.0 * n * n, False)]
        # The bound is 4N² bytes (all of F); the solver skips the rows of patches with reflectivity 0, so it
        # reads less, and its GB/s counts what it reads.
        full = 4.0 * n * n
        fastest, peers = _problem(out, stream, f"Jacobi step, room3.xml, {n} patches (4N² = {full / 1e6:.0f} MB, of which "
                                 f"{nbytes / 1e6:.0f} MB read)", entries)
        if fastest:
            bound = full / (fastest[5] * 1e9)
            targets.append(target(f"Jacobi room3 ({fastest[0]}): its time over that of 4N² bytes at the triad "
                                  f"bandwidth next to it ({fastest[5]:.1f} GB/s)",
                                  Interval.of(fastest[1]["times_s.per_iteration"], 1 / bound), JACOBI_SLACK, "less",
                                  "x"))
            if peers:
                name, recs = min(peers.items(), key=lambda kv: median_of(kv[1], "times_s.per_iteration"))
                targets.append(target(f"Jacobi room3: times faster per step than the best NumPy way, {name}",
                                      faster(recs, fastest[1]), JACOBI_VS_NUMPY, "greater", "x"))
        # F in 16 bits: against our float32 AOS, the same kernel reading half the bytes.
        f32 = mine[mine["params.layout"] == "aos"]
        if len(half) and len(f32):
            entries = [(f"openmp float AOS, F in {v}", half[half["params.ff_precision"] == v], nbytes / 2, True)
                       for v in ("float16", "bfloat16")]
            entries.append(("openmp float AOS, F in float32 (above)", f32, nbytes, True))
            _problem(out, stream, f"Jacobi step, room3.xml, F stored in 16 bits ({nbytes / 2e6:.0f} MB read)", entries)
            f16 = half[half["params.ff_precision"] == "float16"]
            if len(f16):
                targets.append(target("Jacobi room3: times faster per step with F in float16 than in float32 (AOS)",
                                      faster(f32, f16), HALF_VS_FLOAT, "greater", "x"))


def _hemicube_rows(preset, host, out, targets):
    """The hemicube's speed (bench-hemicube), and slurm/hemicube-before-after's commits, before and after."""
    hc = on_host(load("bench-hemicube", preset), host)
    if len(hc):
        pps = median_of(hc, "perf.patches_per_s")
        out.append({"problem": f"Hemicube room3.xml R={int(hc['params.hemicube'].iloc[0])} (iteration = one patch)",
                    "solver": f"ours: {pps:.0f} patches/s, {median_of(hc, 'times_s.hemicube'):.2f} s",
                    "ms per iteration": 1e3 / pps, "repeats": len(hc)})
    # slurm/hemicube-before-after: the program of an older commit and the current one, run in turns.
    hist = on_host(load("hemicube_speed"), host)
    if len(hist):
        groups = sorted(hist.groupby("provenance.git_commit"), key=lambda g: g[1]["provenance.utc"].min())
        for commit, g in groups:
            out.append({"problem": "Hemicube room3.xml R=256, slurm/hemicube-before-after" if commit == groups[0][0]
                        else "", "solver": f"commit {commit[:7]}: {median_of(g, 'perf.patches_per_s'):.0f} patches/s",
                        "ms per iteration": 1e3 / median_of(g, "perf.patches_per_s"), "repeats": len(g)})
        if len(groups) > 1:
            (c0, g0), (c1, g1) = groups[0], groups[-1]
            p0, p1 = median_of(g0, "perf.patches_per_s"), median_of(g1, "perf.patches_per_s")
            targets.append(f"Hemicube room3 R=256: {p0:.0f} patches/s before (commit {c0[:7]}), {p1:.0f} after "
                           f"(commit {c1[:7]}): {p1 / p0:.2f}x")


def rows(preset):
    """(table rows, target lines, host, threads, CPU model), or None when there is no bandwidth record."""
    stream = load("bench-stream", preset)
    if not len(stream):
        return None
    host = stream.sort_values("provenance.utc")["provenance.host"].iloc[-1]
    stream = on_host(stream, host)
    out, targets = [], []
    _cg_rows(preset, host, stream, out, targets)
    _jacobi_rows(preset, host, stream, out, targets)
    _hemicube_rows(preset, host, out, targets)
    # The limit over the whole run: its spread is the neighbours' share of the memory system.
    for name, col in (("STREAM triad", "perf.triad_GBps"), ("read-only sweep", "perf.read_GBps")):
        out.append({"problem": f"limit: {name} (median; min to max: {stream[col].min():.1f} to "
                               f"{stream[col].max():.1f} GB/s)", "solver": "bin/stream", "GB/s": median_of(stream, col),
                    "of triad": median_of(stream, col) / median_of(stream, "perf.triad_GBps"), "repeats": len(stream)})
    return out, targets, host, int(stream["params.threads"].iloc[-1]), stream["provenance.cpu_model"].iloc[-1]


def _fmg_targets(n, rows_n, fmg_setup, triad):
    """Issue 37's targets at N = 8191 or 8192: FMG's solve <= 0.5 s and its whole process <= 1.0 s, both faster than
    the fastest DST solver's (solve against solve, process against process, paired per round), its setup <= 0.35 s
    or <= 1.2x the time to write 3 vectors of N² at the triad bandwidth measured next to it. rows_n: the table's rows
    with their records ("_recs"); fmg_setup: FMG's setup times."""
    fmg = next((r for r in rows_n if "FMG" in r["solver"]), None)
    dst = [r for r in rows_n if "DST" in r["solver"]]
    if not fmg or n not in (8191, 8192):
        return []
    recs = fmg["_recs"]
    write3 = 3 * 8.0 * n * n / (triad * 1e9)
    out = [target(f"FMG N={n}: solve", Interval.of(recs["times_s.solve"]), FMG_SOLVE_S, "less", " s"),
           target(f"FMG N={n}: setup (target {FMG_SETUP_S:g} s, or {SETUP_VS_WRITE:g}x the {write3:.3g} s that 3 "
                  f"vectors of N² take to write at the {triad:.1f} GB/s of triad next to it)", Interval.of(fmg_setup),
                  max(FMG_SETUP_S, SETUP_VS_WRITE * write3), "less", " s")]
    if fmg["process (s)"] is not None:
        out.append(target(f"FMG N={n}: whole process", Interval.of(recs["times_s.process"]), FMG_PROCESS_S, "less",
                          " s"))
    for what, col, key in (("solve", "times_s.solve", "time to solution (s)"),
                           ("whole process", "times_s.process", "process (s)")):
        have = [r for r in dst if r[key] is not None]
        if have and fmg[key] is not None:
            best = min(have, key=lambda r: r[key])
            out.append(target(f"FMG N={n}: {what} over that of the fastest DST solver's, {best['solver']}",
                              faster(recs, best["_recs"], col), 1.0, "less", "x"))
    return out


def _pcg_targets(n, rows_n):
    """Issue 19's targets: MG-PCG (rows_n[0]) against PETSc + BoomerAMG and + GAMG at N = 2048 and 4096 (paired per
    round), N = 8192 in 10 s, at most 12 iterations (a count: margin 0)."""
    first, targets = rows_n[0], []
    for r in rows_n[1:]:
        if n in (2048, 4096) and "hypre" in r["solver"]:
            targets.append(target(f"MG-PCG N={n}: its time over PETSc + BoomerAMG's",
                                  faster(first["_recs"], r["_recs"], "times_s.solve"), MG_VS_HYPRE, "less", "x"))
        if n in (2048, 4096) and "GAMG" in r["solver"]:
            targets.append(target(f"MG-PCG N={n}: its time over PETSc + GAMG's",
                                  faster(first["_recs"], r["_recs"], "times_s.solve"), 1.0, "less", "x"))
    if n == 8192:
        targets.append(target(f"MG-PCG N=8192: time to 1e-6 ({first['iterations']} iterations)",
                              Interval.of(first["_recs"]["times_s.solve"]), MG_8192_S, "less", " s"))
    targets.append(target(f"MG-PCG N={n}: iterations", Interval.of(first["_recs"]["result.iterations"]), 12, "less",
                          exact=True))
    return targets


def mg_rows(preset, host, stream):
    """The bench-mg table (time to solution, iterations, error, DOF/s, the whole process, time / ours) and its target
    lines (stream: the bandwidth records, for the limit next to a case)."""
    from common import backend_facts  # the programs' facts, read where the binaries are built (make bench)
    df = on_host(load("bench-mg", preset), host)
    if not len(df):
        return [], []
    precond = df["params.precond"].fillna("none") if "params.precond" in df else pd.Series("none", df.index)
    method = df["params.method"].fillna("cg") if "params.method" in df else pd.Series("cg", df.index)
    mine, peer = df[df["app"] == "poisson"], df[df["app"] == "peer"]
    out, targets = [], []

    def entry(name, recs, ours_t=None):
        t, it = median_of(recs, "times_s.solve"), int(recs["result.iterations"].median())
        setup = recs["times_s.setup"] + (recs["times_s.pc_setup"].fillna(0) if "times_s.pc_setup" in recs else 0)
        n = float(recs["params.n"].iloc[0])
        return {"solver": name, "iterations": it, "time to solution (s)": t,
                "95% interval (s)": ci_of(recs, "times_s.solve"),
                "ms per iteration": 1e3 * median_of(recs, "times_s.per_iteration"),
                "setup (s)": float(setup.fillna(0).median()),
                "process (s)": median_of(recs, "times_s.process") if "times_s.process" in recs and
                recs["times_s.process"].notna().any() else None,
                "DOF/s": n * n / t if t > 0 else None,
                "error ‖u − u_h‖∞": median_of(recs, "result.error_inf"),
                "time / ours": t / ours_t if ours_t else 1.0, "repeats": len(recs), "_recs": recs}

    for n in sorted(df["params.n"].unique()):
        default = backend_facts.poisson_default_max_iter(int(n))  # bin/poisson --list-backends --json
        cap = lambda r: r["params.max_iter"] < default  # noqa: E731  capped runs: per iteration only
        at_n = mine["params.n"] == n
        o = mine[at_n & (precond[mine.index] == "mg") & (method[mine.index] == "cg")]
        f = mine[at_n & (method[mine.index] == "fmg")]
        ours = [(f"ours: openmp MG-PCG, {int(r['params.threads'].iloc[0])} threads", r) for r in (o,) if len(r)]
        ours += [(f"ours: openmp FMG, then V-cycles, {int(r['params.threads'].iloc[0])} threads", r) for r in (f,)
                 if len(r)]
        if ours:
            first = entry(*ours[0])
            rows_n = [first] + [entry(name, r, first["time to solution (s)"]) for name, r in ours[1:]]
            for pc in ("hypre", "gamg", "mg"):
                p = peer[(peer["params.n"] == n) & (peer["params.precond"] == pc)]
                if len(p):
                    rows_n.append(entry(f"{PETSC[pc]}, {int(p['params.ranks'].iloc[0])} ranks", p,
                                        first["time to solution (s)"]))
            for fft, lib in (("scipy", "scipy.fft"), ("fftw", "FFTW RODFT00")):
                p = peer[(peer["params.n"] == n) & (peer["params.peer"] == f"dst-{fft}")]
                if len(p):
                    rows_n.append(entry(f"DST-I direct solver ({lib}), {int(p['params.threads'].iloc[0])} threads",
                                        p, first["time to solution (s)"]))
            for k, r in enumerate(rows_n):
                out.append({"problem": f"Poisson to 1e-6, N={n}" if k == 0 else "",
                            **{c: v for c, v in r.items() if c != "_recs"}})
            if len(f):
                targets += _fmg_targets(n, rows_n, f["times_s.setup"], limit_next_to(stream, f))
        if len(o):
            targets += _pcg_targets(n, rows_n)
        # Plain CG: ours against PETSc's, full solves (iterations must agree) or capped (time per iteration).
        o = mine[at_n & (precond[mine.index] == "none") & (method[mine.index] == "cg")]
        p = peer[(peer["params.n"] == n) & (peer["params.precond"] == "none")]
        if len(o) and len(p):
            mine_e = entry(f"ours: openmp CG {o['params.variant'].iloc[0]}, {int(o['params.threads'].iloc[0])} threads", o)
            peer_e = entry(f"{PETSC['none']}, {int(p['params.ranks'].iloc[0])} ranks", p, mine_e["time to solution (s)"])
            peer_e["time / ours"] = peer_e["ms per iteration"] / mine_e["ms per iteration"]
            capped = bool(cap(o.iloc[0]))
            title = f"Plain CG, N={n}" + (f", {mine_e['iterations']} iterations (capped): per iteration" if capped
                                          else " to 1e-6")
            out.append({"problem": title, **{c: v for c, v in mine_e.items() if c != "_recs"}})
            out.append({"problem": "", **{c: v for c, v in peer_e.items() if c != "_recs"}})
            if capped:
                targets.append(target(f"Plain CG N={n}: times faster per iteration than PETSc's CG",
                                      faster(p, o), CG_VS_PETSC, "greater", "x"))
            else:
                same = mine_e["iterations"] == peer_e["iterations"]
                targets.append(f"Plain CG N={n}: ours {mine_e['iterations']} iterations, PETSc's {peer_e['iterations']}"
                               f" (the same problem and norm: must agree): {'agree' if same else 'DIFFER'}")
    return out, targets


def markdown(rows, floatfmt):
    """rows (dicts) as a Markdown table, empty cells where a row has no value (not "nan")."""
    return md_table(pd.DataFrame(rows), floatfmt)


def write(preset):
    consistency.reset()
    made = rows(preset)
    if made is None:
        return None
    out, targets, host, threads, cpu = made
    stream = on_host(load("bench-stream", preset), host)
    mg_out, mg_targets = mg_rows(preset, host, stream)
    sp_out, sp_targets = sparse_rows(preset, host, stream)
    table = markdown(out, ".3g")
    head = (f"CPU timings (host wall clock) on {md(host)} ({md(cpu)}), {threads} threads, OMP_PROC_BIND=close, medians over "
            f"the repeats. GB/s: the bytes the solver's data-movement model must move per iteration over its time; "
            f"triad next to it: the STREAM triad bandwidth measured just before and just after the case (median); "
            f"of triad: GB/s over that (ours/limit); time / ours: against our fastest on the "
            f"same problem (peer/ours, > 1: ours is faster). 95% interval: the distribution-free interval of the median, "
            f"its true coverage beside it where the repeats cannot reach 95% (none below 3 repeats); repeats: n. "
            f"Each target is decided by the claims' one rule (analysis/verdict.py) on the interval shown: confirmed "
            f"(met beyond the margin), refuted (missed beyond it), equivalent (within the margin of the target), "
            f"undecided.")
    text = f"### make bench ({preset})\n\n{head}\n\n{table}\n\n" + "".join(f"- {t}\n" for t in targets)
    if mg_out:
        text += (f"\n#### Multigrid against PETSc, hypre and the direct solver ({preset})\n\nTime to solution: the "
                 f"solve alone (ours: the CG iterations with their V-cycles, or FMG's F-cycle and V-cycles; PETSc: "
                 f"ksp.solve after ksp.setUp, whose AMG setup is in setup with the assembly; the DST solver: its two "
                 f"transforms and the division, after making b and the plan); ours on {threads} OpenMP threads, "
                 f"PETSc on as many MPI ranks, the DST solver on as many threads; medians over the repeats, which "
                 f"slurm/bench runs in rounds so ours and the peers alternate. DOF/s: N² over the time to solution "
                 f"(HPGMG's figure). process: the program's whole life up to its record (times_s.process: start-up, imports, setup, "
                 f"solve and check). time / ours: over our first row (> 1: ours is faster); for plain CG per "
                 f"iteration.\n\n"
                 + markdown(mg_out, ".4g") + "\n\n"
                 + "".join(f"- {t}\n" for t in mg_targets))
    if sp_out:
        text += (f"\n#### Sparse form factors: a Jacobi step by storage ({preset})\n\nopenmp, float, AOS, "
                 f"{threads} threads, 32 steps; slurm/bench runs the storages in rounds, so they alternate in the same "
                 f"minutes. MB of F per step: what the product reads (perf.matrix_bytes); time / its limit: the time "
                 f"per step over those bytes at the read-only sweep measured next to each repeat (median over the "
                 f"repeats). its own read sweep: the same arrays of F read, and nothing else done, in the same "
                 f"process on the same threads right after the steps (--read-sweeps; best of 32), so in the same cache "
                 f"state: F read again and again stays partly in a large last-level cache, which bin/stream's "
                 f"256 MiB arrays do not; time / its own limit: the time per step over those bytes at that bandwidth "
                 f"(empty for records made before the bench asked for it).\n\n" + markdown(sp_out, ".3g") + "\n\n"
                 + "".join(f"- {t}\n" for t in sp_targets))
    tables_dir().mkdir(parents=True, exist_ok=True)
    path = tables_dir() / f"bench_{preset}.md"
    path.write_text(text)
    consistency.save(preset, "bench_quotes")
    return text, path


def main():
    preset = sys.argv[1] if len(sys.argv) > 1 else "quick"
    made = write(preset)
    if made is None:
        print(f"bench: no bench-stream records for preset {preset}: run make bench", file=sys.stderr)
        return 1
    text, path = made
    print(text + f"\nbench: wrote {path}")
    try:
        consistency.check(consistency.load(preset))
    except consistency.Disagreement as e:
        print(f"bench: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
