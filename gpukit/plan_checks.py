"""The kit's checks of correctness, as steps and commands of its plan (gpukit/plan.py): every GPU configuration
against float64, the Poisson GPU backends against the CPU, and compute-sanitizer's runs. Standard library only (it
runs on the GPU node)."""
from pathlib import Path

from gpukit.checks import converged_and_agreed, mg_symmetric, poisson_agree, poisson_converged


def agreement_steps(kit, tok, preset, Step, Cmd):
    """Every GPU configuration against float64 on scenes 1 and 2 (the program's own check, verify.agreed); the
    Poisson GPU backends against the CPU at N = 256 and 1024, CG against openmp, the multigrid against serial's
    (iterations within 1, the error to 4 digits) and its V-cycle's symmetry (--check-symmetry)."""
    b = lambda p: str(Path(kit) / "bin" / p)
    scene = lambda k: str(Path(kit) / "radiosity" / "scenes" / f"scene{k}.xml")
    dense = ["--storage", "dense"]
    configs = {"cuda": ["--backend", "cuda", *dense],
               "cuda double": ["--backend", "cuda", "--precision", "double", *dense],
               "cublas": ["--backend", "cublas", *dense], "cublas --fused": ["--backend", "cublas", "--fused", *dense],
               "hybrid 0": ["--backend", "hybrid", "--distribution", "0"],
               "hybrid 0.3": ["--backend", "hybrid", "--distribution", "0.3"],
               "hybrid 0.3 --overlap": ["--backend", "hybrid", "--distribution", "0.3", "--overlap"],
               "hybrid 1": ["--backend", "hybrid", "--distribution", "1"]}
    # the sparse storages on scene 1 (the budget holds no more): cuSPARSE for csr float32, our warp-per-row kernel
    # for compressed
    sparse = {"cuda csr": ["--backend", "cuda", "--storage", "csr"],
              "cuda compressed": ["--backend", "cuda", "--storage", "compressed"],
              "cublas csr": ["--backend", "cublas", "--storage", "csr"]}
    steps = []
    # scene 2: cuda's and cublas's kernels (the budget holds no more; Table 4.5's cases check hybrid's on room2)
    on_scene2 = ("cuda", "cublas --fused")
    scenes = ((1, 1), (2, 2)) if preset == "paper" else ((1, 1),)  # the ci preset makes scene 1's form factors only
    for k, est in scenes:  # seconds a configuration
        ff = str(tok["FF_DIR"] / f"{preset}-scene{k}.ff")
        for name, args in {**configs, **sparse}.items() if k == 1 else [(c, configs[c]) for c in on_scene2]:
            steps.append(Step(f"{name} against float64 on scene {k}", "correctness", est, [
                Cmd([b("radiosity"), "solve", scene(k), "--ff", ff, "--tol", "1e-6", *args], "gpu-correctness",
                    f"kit/agree/scene{k}/{name}", converged_and_agreed, True)]))
    cg = lambda n, be, extra: Cmd([b("poisson"), "--backend", be, *extra, "--n", str(n)],
                                  None if be == "openmp" else "gpu-correctness",
                                  f"kit/poisson-agree/{n}/{be}{'-'.join([''] + extra[1:])}", poisson_converged, True)
    for n, est in ((256, 3), (1024, 5)):
        for what, runs in (("cuda", (("cuda", []), ("cuda", ["--variant", "classic"]))),
                           ("cuBLAS", (("cublas1", []), ("cublas2", [])) if n == 256 else ())):
            if not runs:
                continue
            steps.append(Step(f"Poisson CG {what} against the CPU at N = {n}", "correctness", est,
                              [cg(n, "openmp", [])] + [cg(n, be, extra) for be, extra in runs], poisson_agree))
        steps.append(Step(f"Poisson multigrid on the GPU against serial's at N = {n}", "correctness", 3, [
            Cmd([b("poisson"), "--backend", "serial", "--precond", "mg", "--n", str(n)], None, None,
                poisson_converged, True),
            Cmd([b("poisson"), "--backend", "cuda", "--precond", "mg", "--check-symmetry", "--n", str(n)],
                "gpu-correctness", f"kit/poisson-agree/{n}/cuda-mg", mg_symmetric, True)], poisson_agree))
    return steps


def sanitizer_runs(kit, tok, preset):
    """(memcheck's runs, racecheck's, initcheck's): memcheck on every CUDA backend of both programs at a
    small size; racecheck and initcheck on every kernel that uses shared memory (the radiosity AOS tiles and block
    sums, cuda's; hybrid runs the same kernels; Poisson's one-sweep rings and block sums at N = 300, partial tiles in
    both directions; its classic dots) and initcheck on the multigrid's levels."""
    b = lambda p: str(Path(kit) / "bin" / p)
    s1 = [b("radiosity"), "solve", str(Path(kit) / "radiosity" / "scenes" / "scene1.xml"),
          "--ff", str(tok["FF_DIR"] / f"{preset}-scene1.ff"), "--no-verify"]
    s1d = s1 + ["--storage", "dense"]  # the dense kernels (--storage auto takes a sparse one on cuda, cublas)
    mg = [b("poisson"), "--backend", "cuda", "--precond", "mg", "--n", "50", "--check-symmetry"]
    memcheck = {
        "radiosity cuda float": s1d + ["--backend", "cuda", "--steps", "3"],
        "radiosity cuda double bicgstab": s1d + ["--backend", "cuda", "--precision", "double", "--method", "bicgstab",
                                                "--tol", "1e-5"],
        "radiosity cublas bicgstab": s1d + ["--backend", "cublas", "--method", "bicgstab", "--tol", "1e-5"],
        "radiosity cublas --fused double": s1d + ["--backend", "cublas", "--fused", "--precision", "double",
                                                 "--steps", "3"],
        "radiosity cuda compressed float16": s1 + ["--backend", "cuda", "--storage", "compressed", "--ff-precision",
                                                   "float16", "--steps", "3"],
        "radiosity cuda csr (cuSPARSE)": s1 + ["--backend", "cuda", "--storage", "csr", "--steps", "3"],
        "radiosity hybrid 0.3 --overlap": s1d + ["--backend", "hybrid", "--distribution", "0.3", "--overlap",
                                                "--steps", "3"],
        "poisson cublas1 N=64": [b("poisson"), "--backend", "cublas1", "--n", "64"],
        "poisson cublas2 N=64": [b("poisson"), "--backend", "cublas2", "--n", "64"],
        "poisson cuda one-sweep N=64": [b("poisson"), "--backend", "cuda", "--n", "64"],
        "poisson cuda classic N=64": [b("poisson"), "--backend", "cuda", "--variant", "classic", "--n", "64"],
        "poisson cuda --precond mg N=50": mg,
        "stream --device gpu": [b("stream"), "--device", "gpu", "--size", "1048576", "--trials", "2"],
    }
    shared = {  # stream's kernels are checked by memcheck only: racecheck and initcheck cost too much for them
        "radiosity cuda (tiles, block sums)": s1d + ["--backend", "cuda", "--steps", "2"],
        "poisson cuda one-sweep N=300": [b("poisson"), "--backend", "cuda", "--n", "300", "--steps", "4"],
        "poisson cuda classic N=300": [b("poisson"), "--backend", "cuda", "--variant", "classic", "--n", "300",
                                       "--steps", "4"],
    }
    return memcheck, shared, {**shared, "poisson cuda --precond mg N=50": mg}
