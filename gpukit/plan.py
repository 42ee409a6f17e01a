"""The kit's plan: its steps, most important first, each with its commands, its checks and its estimated seconds on
an H100/H200 node with 16 cores. Standard library only (it runs on the GPU node).

The estimates are derived, not measured on a GPU node (none was at hand when the kit was written): CPU work from
this project's 2-core development machine scaled to 16 cores, GPU work from the bytes it streams at an attained
2.8 TB/s (80% of 3.5: an H100 SXM streams about 3 TB/s, an H200 about 4.3). The plan keeps SLACK of the budget
free (the review of issue 32 found Poisson N = 8192 at about 16 s where an older estimate said 13), and the driver
measures the first steps against their estimates and drops the last ones, by name, when it runs late."""
from pathlib import Path

from common import backend_facts
from gpukit import cases
from gpukit.checks import (converged_and_agreed, gpu_tests_ran, mg_symmetric, poisson_agree, poisson_converged,
                           sanitizer_clean)

PRESET = "paper"
RESERVE_S = 10  # kept back for the summary and the archive
SLACK = 0.2  # the share of the budget the plan leaves free: its steps fit (1 - SLACK) * budget - RESERVE_S
BYTES_PER_S = 2.8e12
# Form factors (hemicube R = 256, the file's write included): room3 took 12.7 s on 2 threads here (docs/design-notes.md), room2
# has 1.77 times its patches and a row's cost grows with the patches in front of it.
FF_ESTIMATE_S = {"scene1.xml": 1, "scene2.xml": 2, "room3.xml": 4, "room2.xml": 12}
SCENE_ESTIMATE_S = {"scene1.xml": 1, "scene2.xml": 2, "room3.xml": 3, "room2.xml": 4}
CUBLAS_BACKENDS = ("cublas1", "cublas2", "cublas")
OVERLAP_AT = (0.2, 0.5, 0.8)  # Table 4.5's d run again with --overlap
OPTIONAL = ("table45-overlap",)  # derived experiments run only when the plan runs early (with racecheck, initcheck)


class Step:
    """A named piece of work: commands run one after the other, each judged by its exit status and its own checks;
    then `check`, if any, judges the records of all of them together (None: passed, else why not). `needs`: what
    of the node it uses beyond the GPU ('cublas', 'cusparse', 'sanitizer'), so that it is skipped, with the
    reason, where the node lacks it. `optional`: a step after the plan, run only when the steps before it ran early
    enough that it still ends within (1 - SLACK) of the budget."""

    def __init__(self, name, group, estimate_s, commands, check=None, optional=False):
        self.name, self.group, self.estimate_s, self.commands, self.check = name, group, estimate_s, commands, check
        self.optional = optional  # after the plan: run only when the measured pace leaves room within the slack
        self.needs = set()
        for c in commands:
            self.needs |= needs_of(c.argv)


class Outcome:
    """What became of one step (or of a probe): 'ok', 'FAILED' or 'skipped', with why and the seconds it took."""

    def __init__(self, name, group, estimate_s, result, measured_s=None, why=""):
        self.name, self.group, self.estimate_s, self.result = name, group, estimate_s, result
        self.measured_s, self.why = measured_s, why


class Cmd:
    """One command. `check` judges the record it prints (--json), `text_check` its output; each returns None when
    it passed, else why not."""

    def __init__(self, argv, experiment=None, case_id=None, check=None, json_out=False, text_check=None):
        self.argv, self.experiment, self.case_id, self.check, self.json_out = argv, experiment, case_id, check, json_out
        self.text_check = text_check


def option(argv, name, default=None):
    argv = [str(x) for x in argv]
    return argv[argv.index(name) + 1] if name in argv[:-1] else default


def needs_of(argv):
    """What of the node's CUDA libraries and tools one command uses beyond the driver."""
    argv = [str(x) for x in argv]
    out = set()
    if Path(argv[0]).name == "compute-sanitizer":
        out.add("sanitizer")
        argv = argv[5:]  # compute-sanitizer --tool T --error-exitcode 9 PROGRAM ...
    if not argv:
        return out
    backend = option(argv, "--backend")
    if backend in CUBLAS_BACKENDS:
        out.add("cublas")
    if Path(argv[0]).name == "solve_tests":
        out |= {"cublas", "cusparse"}
    # cuSPARSE runs the csr float32 product in float (radiosity/solve/gpu/sparse_device.cuh)
    if backend in ("cuda", "cublas") and option(argv, "--storage") == "csr" and \
            option(argv, "--precision", "float") == "float" and option(argv, "--ff-precision", "float32") == "float32":
        out.add("cusparse")
    return out


def case_estimate(c):
    """Estimated seconds of one GPU case, process start to exit: radiosity by its scene, loading F (room2: 1.17 GB)
    and the program's float64 check on 16 cores being most of it; Poisson from the bytes an iteration streams and
    iterations proportional to N (1581 at N = 1024, measured here), plus a second for the process and the host-side
    checks."""
    t = c.line.split()
    if "poisson" in t[0]:
        n = int(option(t, "--n"))
        if option(t, "--precond") == "mg":
            # MG-PCG: 6-7 iterations at every N (measured on the CPU), each a V-cycle of about 40 vector passes
            # over all levels, and the host-side setup of b and u (3-5 s at N = 8192 on 2 cores here, less on 16)
            return round(2 + n * n / 8192 ** 2 + 8 * (6 + 40) * 8 * n * n / BYTES_PER_S)
        vectors = backend_facts.poisson_vectors(c.backend(), option(t, "--variant"), option(t, "--precision", "double"))
        return round(1 + 1581 * n / 1024 * vectors * 8 * n * n / BYTES_PER_S)
    return SCENE_ESTIMATE_S.get(Path(t[2]).name, 10)


def derived(gpu):
    """Cases made from the report's lines: Table 4.5 with --overlap at OVERLAP_AT (never at d = 0 and 1, where
    nothing is copied and --overlap changes nothing: radiosity/solve/gpu/hybrid.cu), Table 4.3 with RRV's 32 fixed
    steps (Table 4.4's runs the same product on other layouts: left out for the budget), and
    scene 4's 32 steps on cuda with float16 F (issue 18's target), compressed: the GPU reads 16-bit F only there."""
    out = []
    for c in gpu:
        if c.experiment == "table45" and float(option(c.line.split(), "--distribution", "0")) in OVERLAP_AT:
            out.append(cases.Case("table45-overlap", c.index, c.line + " --overlap"))
        elif c.experiment == "table43" and "--tol 1e-6" in c.line:
            steps = c.line.replace("--tol 1e-6", "--steps 32")
            out.append(cases.Case(c.experiment + "-steps32", c.index, steps))
            if c.backend() == "cuda" and "room2.xml" in c.line:
                out.append(cases.Case("gpu-float16", c.index, steps.replace(
                    "--storage dense", "--storage compressed --ff-precision float16")))
    return out


def build(kit, tok, sanitizer):
    """Every step, most important first: the form factors (CPU; scene 1 before all: it is what runs where there is
    no GPU), the GPU's bandwidth, the correctness checks, memcheck, the report's GPU cases, the cases derived from
    them; then the optional steps: Table 4.5 with --overlap, racecheck and initcheck. `tok`: the case lists' tokens; `sanitizer`: compute-sanitizer's path or None."""
    kit = Path(kit)
    b = lambda p: str(kit / "bin" / p)

    def kit_argv(c):  # a case's command with the kit's binaries
        argv = c.argv(tok)
        return [b(argv[0].split("/")[-1])] + argv[1:]

    steps = []
    for c in cases.read(kit / "cases" / PRESET / "formfactors.txt"):
        scene = Path(c.argv(tok)[2]).name
        steps.append(Step(f"form factors of {scene}", "formfactors", FF_ESTIMATE_S.get(scene, 30),
                          [Cmd(kit_argv(c))]))  # CPU work: not recorded (the archive holds GPU records)
    steps.append(Step("GPU triad and read sweep (bin/stream --device gpu)", "bandwidth", 5,
                      [Cmd([b("stream"), "--device", "gpu"], "gpu-stream", "kit/gpu-stream")]))
    steps.append(Step("GPU unit tests (solve_tests --gtest_filter='Cuda*')", "correctness", 8,
                      [Cmd([b("solve_tests"), "--gtest_filter=Cuda*"], text_check=gpu_tests_ran)]))
    steps += agreement_steps(kit, tok)
    memcheck, shared, initcheck = sanitizer_runs(kit, tok)
    san = lambda tool, runs, est, optional=False: [Step(f"compute-sanitizer {tool}: {name}", "sanitizer", est, [Cmd(
        [sanitizer or "compute-sanitizer", "--tool", tool, "--error-exitcode", "9", *argv, "--quiet"],
        text_check=sanitizer_clean)], optional=optional) for name, argv in runs.items()]
    steps += san("memcheck", memcheck, 4)
    gpu = cases.gpu_cases(kit / "cases" / PRESET)
    for c in gpu + derived(gpu):
        argv = kit_argv(c)
        check = poisson_converged if "poisson" in argv[0] else converged_and_agreed
        steps.append(Step(f"{c.experiment} case {c.index}: {c.line}", c.experiment, case_estimate(c),
                          [Cmd(argv, c.experiment, c.case_id, check, True)], optional=c.experiment in OPTIONAL))
    steps = [s for s in steps if not s.optional] + [s for s in steps if s.optional]
    steps += san("racecheck", shared, 6, True) + san("initcheck", initcheck, 4, True)
    return steps


def agreement_steps(kit, tok):
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
    for k, est in ((1, 1), (2, 2)):  # seconds a configuration
        ff = str(tok["FF_DIR"] / f"{PRESET}-scene{k}.ff")
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


def sanitizer_runs(kit, tok):
    """(memcheck's runs, racecheck's, initcheck's): memcheck on every CUDA backend of both programs at a
    small size; racecheck and initcheck on every kernel that uses shared memory (the radiosity AOS tiles and block
    sums, cuda's; hybrid runs the same kernels; Poisson's one-sweep rings and block sums at N = 300, partial tiles in
    both directions; its classic dots) and initcheck on the multigrid's levels."""
    b = lambda p: str(Path(kit) / "bin" / p)
    s1 = [b("radiosity"), "solve", str(Path(kit) / "radiosity" / "scenes" / "scene1.xml"),
          "--ff", str(tok["FF_DIR"] / f"{PRESET}-scene1.ff"), "--no-verify"]
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


def print_plan(steps, budget):
    """The plan, every step with its estimated seconds: 'run' for the steps that fit (1 - SLACK) of the budget,
    'if early' for the optional ones after them, 'skip (budget)' for the rest. Returns the seconds of 'run'."""
    total, rows, room = 0, [], (1 - SLACK) * budget - RESERVE_S
    for s in steps:
        fits = not s.optional and total + s.estimate_s <= room
        total += s.estimate_s if fits else 0
        rows.append((s.group, s.name, s.estimate_s, "run" if fits else "if early" if s.optional else "skip (budget)"))
    print(f"gpu-kit plan: {len(steps)} steps, budget {budget:.0f} s ({RESERVE_S} s kept for the summary and the "
          f"archive, {SLACK:.0%} as slack); estimated seconds on an H100/H200 node with 16 cores")
    for g, n, e, what in rows:
        print(f"  {e:5d} s  {what:14s} [{g}] {n}")
    print(f"  total of the steps that fit: {total} s of {room:.0f} s")
    return total
