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
from analysis.bench_records import ci_of, limit_next_to, median_of, on_host
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
    return fastest, {name: t for name, _, _, mine, t, _ in entries if not mine}


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
                frac = fastest[2] / fastest[4] / 1e9 / fastest[5]
                targets.append(f"CG N=2048 ({fastest[0]}): {100 * frac:.0f}% of the triad bandwidth next to it "
                               f"({fastest[5]:.1f} GB/s; target >= "
                               f"{100 * CG_FRACTION:.0f}%): {'met' if frac >= CG_FRACTION else 'NOT met'}")
                for name, t in peers.items():
                    x = t / fastest[4]
                    targets.append(f"CG N=2048: {x:.1f}x faster per iteration than {name} (target >= "
                                   f"{CG_VS_SCIPY:g}x): {'met' if x >= CG_VS_SCIPY else 'NOT met'}")


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
            targets.append(f"Jacobi room3 ({fastest[0]}): {fastest[4] / bound:.2f}x the time of 4N² bytes at the "
                           f"triad bandwidth next to it ({fastest[5]:.1f} GB/s; target <= {JACOBI_SLACK}x): "
                           f"{'met' if fastest[4] <= JACOBI_SLACK * bound else 'NOT met'}")
            if peers:
                name, t = min(peers.items(), key=lambda kv: kv[1])
                x = t / fastest[4]
                targets.append(f"Jacobi room3: {x:.1f}x faster per step than the best NumPy way, {name} (target >= "
                               f"{JACOBI_VS_NUMPY:g}x): {'met' if x >= JACOBI_VS_NUMPY else 'NOT met'}")
        # F in 16 bits: against our float32 AOS, the same kernel reading half the bytes.
        f32 = mine[mine["params.layout"] == "aos"]
        if len(half) and len(f32):
            entries = [(f"openmp float AOS, F in {v}", half[half["params.ff_precision"] == v], nbytes / 2, True)
                       for v in ("float16", "bfloat16")]
            entries.append(("openmp float AOS, F in float32 (above)", f32, nbytes, True))
            _problem(out, stream, f"Jacobi step, room3.xml, F stored in 16 bits ({nbytes / 2e6:.0f} MB read)", entries)
            t32 = median_of(f32, "times_s.per_iteration")
            f16 = half[half["params.ff_precision"] == "float16"]
            if len(f16):
                x = t32 / median_of(f16, "times_s.per_iteration")
                targets.append(f"Jacobi room3: F in float16 {x:.2f}x faster per step than in float32 (AOS; target >= "
                               f"{HALF_VS_FLOAT:g}x): {'met' if x >= HALF_VS_FLOAT else 'NOT met'}")


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
    the fastest DST solver's (solve against solve, process against process), its setup <= 0.35 s or <= 1.2x the time
    to write 3 vectors of N² at the triad bandwidth measured next to it."""
    fmg = next((r for r in rows_n if "FMG" in r["solver"]), None)
    dst = [r for r in rows_n if "DST" in r["solver"]]
    if not fmg or n not in (8191, 8192):
        return []
    t, proc = fmg["time to solution (s)"], fmg["process (s)"]
    write3 = 3 * 8.0 * n * n / (triad * 1e9)
    setup_ok = fmg_setup <= FMG_SETUP_S or fmg_setup <= SETUP_VS_WRITE * write3
    out = [f"FMG N={n}: solve {t:.3g} s (target <= {FMG_SOLVE_S:g} s): {'met' if t <= FMG_SOLVE_S else 'NOT met'}",
           f"FMG N={n}: setup {fmg_setup:.3g} s (target <= {FMG_SETUP_S:g} s, or <= {SETUP_VS_WRITE:g}x the "
           f"{write3:.3g} s that 3 vectors of N² take to write at the {triad:.1f} GB/s of triad next to it): "
           f"{'met' if setup_ok else 'NOT met'}"]
    if proc is not None:
        out.append(f"FMG N={n}: whole process {proc:.3g} s (target <= {FMG_PROCESS_S:g} s): "
                   f"{'met' if proc <= FMG_PROCESS_S else 'NOT met'}")
    for what, col in (("solve", "time to solution (s)"), ("whole process", "process (s)")):
        have = [r for r in dst if r[col] is not None]
        if have and fmg[col] is not None:
            best = min(have, key=lambda r: r[col])
            x = fmg[col] / best[col]
            out.append(f"FMG N={n}: {what} {x:.2f}x that of the fastest DST solver's, {best['solver']} "
                       f"({fmg[col]:.3g} s against {best[col]:.3g} s; target < 1): {'met' if x < 1 else 'NOT met'}")
    return out


def _pcg_targets(n, rows_n):
    """Issue 19's targets: MG-PCG (rows_n[0]) against PETSc + BoomerAMG and + GAMG at N = 2048 and 4096, N = 8192 in
    10 s, at most 12 iterations."""
    first, targets = rows_n[0], []
    t = first["time to solution (s)"]
    for r in rows_n[1:]:
        if n in (2048, 4096) and "hypre" in r["solver"]:
            x = t / r["time to solution (s)"]
            targets.append(f"MG-PCG N={n}: {t:.3g} s, {x:.2f}x PETSc + BoomerAMG's {r['time to solution (s)']:.3g} "
                           f"s (target <= {MG_VS_HYPRE}x): {'met' if x <= MG_VS_HYPRE else 'NOT met'}")
        if n in (2048, 4096) and "GAMG" in r["solver"]:
            targets.append(f"MG-PCG N={n}: {t:.3g} s against PETSc + GAMG's {r['time to solution (s)']:.3g} "
                           f"s (target: below): {'met' if t < r['time to solution (s)'] else 'NOT met'}")
    if n == 8192:
        targets.append(f"MG-PCG N=8192: {t:.3g} s to 1e-6 in {first['iterations']} iterations (target <= "
                       f"{MG_8192_S:g} s): {'met' if t <= MG_8192_S else 'NOT met'}")
    targets.append(f"MG-PCG N={n}: {first['iterations']} iterations (target <= 12): "
                   f"{'met' if first['iterations'] <= 12 else 'NOT met'}")
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
                "time / ours": t / ours_t if ours_t else 1.0, "repeats": len(recs)}

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
                out.append({"problem": f"Poisson to 1e-6, N={n}" if k == 0 else "", **r})
            if len(f):
                targets += _fmg_targets(n, rows_n, float(f["times_s.setup"].median()), limit_next_to(stream, f))
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
            out.append({"problem": title, **mine_e})
            out.append({"problem": "", **peer_e})
            x = peer_e["time / ours"]
            if capped:
                targets.append(f"Plain CG N={n}: {x:.1f}x faster per iteration than PETSc's CG (target >= "
                               f"{CG_VS_PETSC:g}x): {'met' if x >= CG_VS_PETSC else 'NOT met'}")
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
            f"same problem (peer/ours, > 1: ours is faster). 95% interval: the bootstrap interval of the median "
            f"(none below 3 repeats); repeats: n.")
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
