"""Speed against accuracy and the extremes (issue 6): case lists for slurm/cases/generate.py."""
from presets import SCENES, scene_args


# Speed against accuracy (issue 6). Each sweep varies one setting of the report's default run
# (Jacobi to 1e-6 in float, dense float32 F, the preset's form factors) and every solve record carries its error
# against a float64 solution converged to 1e-12 (bin/radiosity solve: result.error_vs_reference); the form-factor
# sweeps take theirs from a finer hemicube or mesh. quick: about four minutes on 2 cores, one thread per solve (the
# development machine is shared; one thread keeps the times comparable); ci: a few seconds; paper: the report's
# scenes, all cores.
ACCURACY = {
    "quick": dict(threads=1, scenes=[1, 2], hemicube={1: ([32, 64, 128, 256], 512), 2: ([32, 64, 128], 256)},
                  mesh={1: ([4, 2, 1], 0.25), 2: ([4, 2, 1], 0.5)}, mesh_hemicube=128, poisson_n=[1, 2, 1024]),
    "ci": dict(threads=1, scenes=[1], hemicube={1: ([16], 32)}, mesh={1: ([4], 1)}, mesh_hemicube=16,
               poisson_n=[1, 2]),
    "paper": dict(threads="{CORES}", scenes=[1, 2, 3, 4],
                  hemicube={1: ([32, 64, 128, 256, 512], 1024), 2: ([32, 64, 128, 256, 512], 1024),
                            3: ([32, 64, 128, 256], 512)},
                  mesh={1: ([4, 2, 1, 0.5], 0.125), 2: ([4, 2, 1, 0.5], 0.25)}, mesh_hemicube=256,
                  poisson_n=[1, 2, 1024, 4096]),
}
TOLERANCES = [10.0 ** -k for k in range(1, 11)]
STEPS = [1, 2, 4, 8, 16, 32, 64]
THRESHOLDS = [0, 1e-8, 1e-7, 1e-6, 1e-5, 1e-4, 1e-3]
ROOM3_THRESHOLDS = [0, 1e-6, 1e-4]  # docs/design-notes.md, "Speed against accuracy": dense and CSR memory and their error
EXTREME_RHO = ["0.9", "0.99", "0.999", "0.9999"]
# Closed boxes whose light is amplified, not absorbed (issue 54): no physical answer, every method in both precisions
# must say so (exit 3, or 4 where it stops at --max-iter), never 0.
AMPLIFIED_RHO = ["1", "1.05", "1.2"]
METHODS = ("jacobi", "gauss-seidel", "sor --omega 1.2", "bicgstab")


def accuracy(preset, p):
    a = ACCURACY[preset]
    t, cores = a["threads"], p["threads"]
    solve = "bin/radiosity solve"
    default = f"--backend openmp --threads {t}"

    def ff_file(s, divide, R):
        return f"{{FF_DIR}}/{preset}-acc-{SCENES[s][0]}-d{divide:g}-R{R}.ff"

    def scene(s):
        return f"{SCENES[s][1]}{SCENES[s][2]}"

    ff_cases = {}  # (scene, divide, R) -> line, each file once
    for s, (rs, ref) in a["hemicube"].items():
        for R in [*rs, ref]:
            ff_cases[(s, 1.0, R)] = None
    for s, (ds, ref) in a["mesh"].items():
        for d in [*ds, ref]:
            ff_cases[(s, d, a["mesh_hemicube"])] = None
    e = {}
    e["accuracy-formfactors"] = ("Speed against accuracy: form factors for the hemicube and mesh sweeps, and the "
                                 "closed boxes of the extremes", 1, [
        *(f"bin/radiosity formfactors {scene(s)} --divide {d:g} -o {ff_file(s, d, R)} --hemicube {R} --weights exact "
          f"--threads {cores}" for (s, d, R) in ff_cases),
        *(f"bin/radiosity formfactors {box}{ge1(name)} --divide {div} -o {{FF_DIR}}/{preset}-ext-{name}.ff --hemicube 256 "
          f"--weights exact --threads {cores}" for name, box, div in extreme_boxes())])
    # Float's rounding floors the error near 1e-7: tolerances below it run in double (in float BiCG-STAB would only
    # spend max_iter iterations not reaching them).
    e["accuracy-tolerance"] = ("Speed against accuracy: Jacobi and BiCG-STAB tolerance 1e-1 ... 1e-6 in float, 1e-6 "
                               "... 1e-10 in double; Jacobi fixed steps 1 ... 64; Gauss-Seidel and SOR (omega 1.2) "
                               "1e-1 ... 1e-6 in float", 1, [
        *(f"{solve} {scene_args(s, preset)} --method {m} --tol {tol:g} --precision {prec} {default}"
          for s in a["scenes"] for m in ("jacobi", "bicgstab") for tol in TOLERANCES
          for prec in (("float",) if tol > 1e-6 else ("float", "double") if tol == 1e-6 else ("double",))),
        *(f"{solve} {scene_args(s, preset)} --steps {k} {default}" for s in a["scenes"] for k in STEPS),
        # Gauss-Seidel and SOR (issue 21) beside them, in float
        *(f"{solve} {scene_args(s, preset)} --method {m} --tol {tol:g} --backend openmp --threads {th}"
          for s in a["scenes"] for m, th in (("gauss-seidel", t), ("sor --omega 1.2", 1))
          for tol in TOLERANCES if tol >= 1e-6)])
    e["accuracy-precision"] = ("Speed against accuracy: float64, float32, and float32 with F stored as float16 and "
                               "bfloat16, to 1e-6 and after 100 steps", 1, [
        f"{solve} {scene_args(s, preset)} {stop} --precision {prec} --ff-precision {ffp} {default}"
        for s in a["scenes"] for stop in ("--tol 1e-6", "--steps 100")
        for prec, ffp in (("double", "float32"), ("float", "float32"), ("float", "float16"), ("float", "bfloat16"))])
    e["accuracy-threshold"] = ("Speed against accuracy: form factors |F_ij| <= T dropped (CSR), T = 0 ... 1e-3; room3 "
                               "dense and CSR at 0, 1e-6, 1e-4", 1, [
        *(f"{solve} {scene_args(s, preset)} --tol 1e-6 --storage csr --threshold {T:g} {default}"
          for s in a["scenes"] for T in THRESHOLDS),
        *(f"{solve} {scene_args(3, preset)} --tol 1e-6 --storage {st} --threshold {T:g} {default}"
          for T in ROOM3_THRESHOLDS for st in ("dense", "csr") if 3 in p["scenes"])])
    e["accuracy-hemicube"] = ("Speed against accuracy: hemicube resolution, error against the finest hemicube", 1, [
        f"{solve} {scene(s)} --ff {ff_file(s, 1.0, R)} --reference-ff {ff_file(s, 1.0, ref)} --tol 1e-6 {default}"
        for s, (rs, ref) in a["hemicube"].items() for R in rs])
    e["accuracy-mesh"] = ("Speed against accuracy: maximum patch area (--divide), error against the finest mesh's "
                          "solution by area-weighted means", 1, [
        f"{solve} {scene(s)} --divide {d:g} --ff {ff_file(s, d, a['mesh_hemicube'])} "
        f"--reference-ff {ff_file(s, ref, a['mesh_hemicube'])} --reference-divide {ref:g} --tol 1e-6 {default}"
        for s, (ds, ref) in a["mesh"].items() for d in ds])
    boxes = {name: (box, div) for name, box, div in extreme_boxes()}

    def box_solve(name, args):
        box, div = boxes[name]
        return f"{solve} {box}{ge1(name)} --divide {div} --ff {{FF_DIR}}/{preset}-ext-{name}.ff {args} {default}"

    e["extremes"] = ("Extremes: closed box rho 0.9 ... 0.9999, emission 1e30 and 1e-30 in float, faces of area 1e-8 "
                     "and 1e8; Poisson CG in float and double, N = 1, 2 and large; closed box rho 1, 1.05, 1.2 (no "
                     "physical answer), every method in float and double", 1, [
        *(box_solve(f"rho{r}", f"--tol 1e-6 --precision {prec} --max-iter 200000")
          for r in EXTREME_RHO for prec in ("double", "float")),
        *(box_solve(f"rho{r}", "--method bicgstab --tol 1e-6 --precision double") for r in EXTREME_RHO),
        *(box_solve(f"emission{x}", f"--method {m} --tol 1e-6 --precision float")
          for x in ("1e30", "1e-30") for m in ("jacobi", "bicgstab")),
        *(box_solve(f"side{x}", "--tol 1e-6 --precision float") for x in ("1e-4", "1e4")),
        *(f"bin/poisson --n {n} --precision {prec} --backend openmp --threads {t} --max-iter 100000"
          for n in a["poisson_n"] for prec in ("float", "double")),
        *(box_solve(f"rho{r}", f"--method {m} --tol 1e-6 --precision {prec} --max-iter 200000")
          for r in AMPLIFIED_RHO for m in METHODS for prec in ("float", "double"))])
    return e


def ge1(name):
    """RRV's scenes refuse a reflectivity of 1 or more unless asked: the amplifying boxes ask."""
    return " --allow-reflectivity-ge-1" if name.startswith("rho") and name[3:] in AMPLIFIED_RHO else ""


def extreme_boxes():
    """(name, scene, --divide) of radiosity/scenes/extremes/: 192 patches each (every half face split in 16)."""
    d = "radiosity/scenes/extremes"
    return [*((f"rho{r}", f"{d}/box_rho{r}.xml", "0.1") for r in EXTREME_RHO),
            *((f"emission{x}", f"{d}/box_emission{x}.xml", "0.1") for x in ("1e30", "1e-30")),
            ("side1e-4", f"{d}/box_side1e-4.xml", "1e-9"), ("side1e4", f"{d}/box_side1e4.xml", "1e7"),
            *((f"rho{r}", f"{d}/box_rho{r}.xml", "0.1") for r in AMPLIFIED_RHO)]
