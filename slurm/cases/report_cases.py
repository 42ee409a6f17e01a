"""The report's experiments (Tables 4.1-4.5, Figure 4.2, the form factors they read) and the audit of Table
4.2's iteration counts: case lists for slurm/cases/generate.py."""
from presets import PRESETS, REPORT_JACOBI_ITERS, SCENES, figure42_scene, scene_args

OVERLAP_AT = (0.2, 0.5, 0.8)  # Table 4.5's d run again with --overlap


def experiments(preset, p):
    e = {}
    tr = p.get("timing_repeat")  # None: run-case's default, 5
    mt = f" --min-time {p['min_time']:g}" if p.get("min_time") else ""  # the timed solves' (presets.py)

    def long(n):  # plain CG on the CPU at a size whose runs take many minutes: fewer runs (the line says so)
        k = p.get("long_repeat", {}).get(n)
        return f"repeat={k} " if k else ""
    e["table41"] = ("Table 4.1 / Figure 4.1: Poisson CG to 1e-6, MPI processes and the CUDA variants", tr, [
        *(f"{long(n)}ranks={r} bin/poisson --backend mpi --n {n} --max-iter 100000{mt}" for n in p["poisson_n"]
          for r in p["ranks"]),
        *(f"{long(n)}bin/poisson --backend openmp --threads {p['threads']} --n {n} --max-iter 100000{mt}"
          for n in p["poisson_n"]),
        *(f"bin/poisson --backend {b} --n {n} --max-iter 100000{mt}" for n in p["poisson_n"] for b in ("cublas1", "cublas2", "cuda")),
        # Beyond the report (issue 19): CG preconditioned by one multigrid V-cycle, on every p and the GPU.
        *(f"ranks={r} bin/poisson --backend mpi --n {n} --precond mg{mt}" for n in p["mg_n"] for r in p["ranks"]),
        *(f"bin/poisson --backend openmp --threads {p['threads']} --n {n} --precond mg{mt}" for n in p["mg_n"]),
        *(f"bin/poisson --backend cuda --n {n} --precond mg{mt}" for n in p["mg_n"]),
    ])
    e["formfactors"] = ("Form factors of every scene, computed once (the other radiosity experiments read them)", 1, [
        *(f"bin/radiosity formfactors {SCENES[s][1]}{SCENES[s][2]} -o {{FF_DIR}}/{preset}-{SCENES[s][0]}.ff "
          f"--hemicube {p['hemicube']} --weights {p['weights']}" for s in p["scenes"]),
        *([f"bin/radiosity formfactors {figure42_scene(preset, p, ff='-o')} --hemicube {p['figure42']['hemicube']} "
           f"--weights {p['weights']}"] if 3 not in p["scenes"] else [])])
    solve = "bin/radiosity solve"
    e["table42"] = ("Table 4.2: OpenMP Jacobi vs. BiCG-STAB to a relative residual of 1e-6, and Gauss-Seidel beside "
                    "them", tr, [
        f"{solve} {scene_args(s, preset)} --method {m} --tol 1e-6 --backend openmp --layout aos{mt}"
        for s in p["scenes"] for m in ("jacobi", "bicgstab", "gauss-seidel",
                                       # SOR on one thread (several threads couple blocks by over-relaxed Jacobi,
                                       # which may diverge); omega 1.4: the fewest sweeps on room3 in the audit
                                       "sor --omega 1.4 --threads 1")])
    # Table 4.3's OpenMP column is its own run (no table borrows another's column, issue 50), in the same block of
    # rounds as Table 4.2 and 4.4 (generate.py, BLOCKS), so that the claims comparing them are paired.
    e["table43"] = ("Table 4.3: AOS Jacobi to 1e-6: Original (RRV's loop, the report's iterations), Serial, CUDA, "
                    "OpenMP", tr, [
        *(line for s in p["scenes"] for line in (
            f"{solve} {scene_args(s, preset)} --backend original --steps {REPORT_JACOBI_ITERS[s]}{mt}",
            f"{solve} {scene_args(s, preset)} --tol 1e-6 --backend serial --layout aos{mt}",
            f"{solve} {scene_args(s, preset)} --tol 1e-6 --backend cuda --layout aos{mt}")),
        *(f"{solve} {scene_args(s, preset)} --tol 1e-6 --backend openmp --layout aos{mt}" for s in p["scenes"])])
    # Table 4.4 repeats 4.3's Original column in the report: here its own runs (appended: the others keep their ids)
    e["table44"] = ("Table 4.4: SOA Jacobi to 1e-6: Original (RRV's loop, the report's iterations), Serial, CUDA "
                    "(cuBLAS per channel, and fused), OpenMP", tr, [
        *(line for s in p["scenes"] for line in (
            f"{solve} {scene_args(s, preset)} --tol 1e-6 --backend serial --layout soa{mt}",
            f"{solve} {scene_args(s, preset)} --tol 1e-6 --backend cublas --layout soa{mt}",
            f"{solve} {scene_args(s, preset)} --tol 1e-6 --backend cublas --layout soa --fused{mt}",
            f"{solve} {scene_args(s, preset)} --tol 1e-6 --backend openmp --layout soa{mt}")),
        *(f"{solve} {scene_args(s, preset)} --backend original --steps {REPORT_JACOBI_ITERS[s]}{mt}" for s in p["scenes"])])
    hs = p["hybrid_scene"]
    e["table45"] = (f"Table 4.5: hybrid CPU/GPU Jacobi to 1e-6 on scene {hs}, distribution factor 0.0 .. 1.0", tr, [
        f"{solve} {scene_args(hs, preset)} --tol 1e-6 --backend hybrid --layout aos --distribution {d / 10:.1f}{mt}"
        for d in range(11)])
    # The GPU's cases beyond the report's lines (the GPU kit runs them, gpukit/plan.py): Table 4.5 again with
    # --overlap where something is copied (never at d = 0 and 1, where --overlap changes nothing:
    # radiosity/solve/gpu/hybrid.cu); Table 4.3's CUDA with RRV's 32 fixed steps; and the largest scene's 32 steps
    # with float16 F, compressed (issue 18's target: the GPU reads 16-bit F only there).
    e["table45-overlap"] = (f"Table 4.5 with --overlap: hybrid CPU/GPU Jacobi to 1e-6 on scene {hs}, distribution "
                            f"factor {', '.join(f'{d:.1f}' for d in OVERLAP_AT)}", tr, [
        f"{solve} {scene_args(hs, preset)} --tol 1e-6 --backend hybrid --layout aos --distribution {d:.1f}{mt} "
        "--storage dense --overlap" for d in OVERLAP_AT])
    steps32 = lambda s: f"{solve} {scene_args(s, preset)} --steps 32 --backend cuda --layout aos{mt}"
    e["table43-steps32"] = ("Table 4.3's CUDA (AOS) with RRV's 32 fixed Jacobi steps", tr,
                            [steps32(s) for s in p["scenes"]])
    e["gpu-float16"] = (f"Scene {max(p['scenes'])}, 32 Jacobi steps on CUDA (AOS) with float16 F, compressed", tr,
                        [steps32(max(p["scenes"])) + " --storage compressed --ff-precision float16"])
    # The report's scene 3 (RRV's room3.xml) from its camera; ci (no room3 among its scenes) coarsens it
    # (--divide 8: 5960 patches) and takes a small hemicube, so that its run is seconds.
    e["figure42"] = ("Figure 4.2: scene 3 after 1, 2, 4, 8 and 32 Jacobi steps", 1, [
        f"{solve} {figure42_scene(preset, p)} --steps 32 --backend openmp --snapshots 1,2,4,8,32 "
        f"--snapshot-prefix {{RESULTS}}/figure42/{{PRESET}}/room3 --view -9.5,3,9.5:0,-5,-3:70 --size 320x240"])
    return e


# Table 4.2 audited (issue 21): which stopping rule and start give the report's iteration counts. For each audit
# scene, both hemicube weights (exact, RRV's 2007 cos·cos) and both starts (RRV's max(radiosity, emission), zero):
# Jacobi and BiCG-STAB to 1e-6 under every rule, each run's own count (--history keeps the residuals, so the
# analysis replays the rule and checks the count); Gauss-Seidel on 1 thread and on all cores (its count depends on
# the thread blocks); deep histories in double to 1e-10 for the tolerance intervals and the plot; SOR over omega.
# Counts do not vary between repeats: one run each, no float64 check (--no-verify: the audit needs counts, and a
# squared rule's loose answers would only fail it). The form factors of both weights are this experiment's own.
# BiCG-STAB does not start from zero here: with x_0 = 0 its shadow residual r^ = r_0 = e lives on the lights, and
# where a light does not reflect (rho = 0 in a channel) the first step makes r_1 vanish there, so r^.r_1 = 0 and it
# breaks down at iteration 2 (exit 3) on scene1 and room3 alike (tests/integration/test_table42_audit.py): from zero,
# the report's 17 iterations could not have been counted with r^ = r_0.
STOP_BASES = ["residual-e", "residual-r0", "residual-b", "step-2", "step-inf"]
STOP_RULES = [b + m for b in STOP_BASES for m in ("", "+stacked", "+squared", "+stacked+squared")]
AUDIT = {
    "quick": dict(scenes=[3], rules=STOP_RULES, omegas=[0.8, 1.2, 1.4, 1.6], gs_threads=[1, 2, 4, 8, 16]),
    "ci": dict(scenes=[1], rules=["residual-e", "residual-r0+stacked", "step-inf+squared"], omegas=[1.2],
               gs_threads=[1, 2]),
    "paper": dict(scenes=[3, 4], rules=STOP_RULES, omegas=[0.8, 1.2, 1.4, 1.6], gs_threads=[1, 2, 4, 8, 16]),
}
AUDIT_WEIGHTS = ["exact", "rrv2007"]
AUDIT_STARTS = ["rrv", "zero"]


def audit_ff(preset, s, w):
    """The audit's form factors of scene s with weights w: the preset's own (experiment formfactors, run first by
    make reproduce and slurm/submit) where its weights are w, else the audit's file."""
    if w == PRESETS[preset]["weights"]:
        return f"{{FF_DIR}}/{preset}-{SCENES[s][0]}.ff"
    return f"{{FF_DIR}}/{preset}-audit-{SCENES[s][0]}-{w}.ff"


def table42_audit(preset, p):
    a = AUDIT[preset]
    cores = p["threads"]
    solve = "bin/radiosity solve"

    def run(s, w, args):
        return (f"{solve} {SCENES[s][1]}{SCENES[s][2]} --ff {audit_ff(preset, s, w)} {args} --backend openmp "
                f"--layout aos --no-verify --history")

    e = {}
    e["table42-audit-formfactors"] = ("Table 4.2 audited: form factors of the audit's scenes with exact and RRV's "
                                      "weights", 1, [
        f"bin/radiosity formfactors {SCENES[s][1]}{SCENES[s][2]} -o {audit_ff(preset, s, w)} --hemicube {p['hemicube']} "
        f"--weights {w} --threads {cores}" for s in a["scenes"] for w in AUDIT_WEIGHTS if w != p["weights"]])
    e["table42-audit"] = ("Table 4.2 audited: stopping rule x start -> Jacobi, BiCG-STAB (and Gauss-Seidel) iterations "
                          "to 1e-6, deep histories, SOR over omega", 1, [
        line for s in a["scenes"] for w in AUDIT_WEIGHTS for start in AUDIT_STARTS for line in (
            *(run(s, w, f"--method {m} --tol 1e-6 --stop {rule} --start {start} --threads {cores}")
              for m in ("jacobi", "bicgstab") for rule in a["rules"] if (m, start) != ("bicgstab", "zero")),
            *(run(s, w, f"--method gauss-seidel --tol 1e-6 --start {start} --threads {t}")
              for t in a["gs_threads"]),
            *(run(s, w, f"--method {m} --tol 1e-10 --precision double --start {start} --threads {cores}")
              for m in ("jacobi", "gauss-seidel", "bicgstab") if (m, start) != ("bicgstab", "zero")),
            # one thread: SOR proper (on several threads the blocks are coupled by Jacobi, and over-relaxed Jacobi
            # diverges where F has eigenvalues near -1/rho: scene2 at omega 1.2 on 2 threads does; docs/programs.md)
            *(run(s, w, f"--method sor --omega {o:g} --tol 1e-6 --start {start} --threads 1")
              for o in a["omegas"] if w == "exact" and start == "rrv"))])
    return e
