"""The kit's plan: its steps in the order that keeps what matters when time runs short, each with its commands, its
checks and its estimated seconds on an H100/H200 node with 16 cores. Standard library only (it runs on the GPU node).

The order, by phase (PHASES), most important first:
  probe        the GPU's triad and read sweep: the limit every GPU number is judged by
  inputs       the form factors of the preset's scenes, on the node's CPUs (the radiosity cases read them)
  tables       round 1: every GPU cell of the report's Tables 4.1 (N = 8192's plain CG aside), 4.3, 4.4 and 4.5 once,
               with the CPU cells on the node that the GPU claims set them against (OpenMP on the node's cores: Table
               4.1 at the N where the CPU takes seconds, Tables 4.3's and 4.4's OpenMP)
  claims       rounds 2..ROUNDS of the groups each claim compares, cheapest group first, as many groups as the
               budget holds beside the other phases up to memcheck: the cases of a group run side by side in each
               round, their order reversed from one round to the next (paired and interleaved), so that a claim is
               decided on per-round ratios of ROUNDS pairs (a distribution-free 95% interval needs 6)
  targets      the speed targets: Poisson plain CG at N = 8192 on cuda (a Table 4.1 cell too), scene 4's 32 Jacobi
               steps with float32 and float16 F
  memcheck     compute-sanitizer memcheck on every CUDA backend of both programs
  claims-more  the rounds of the claim groups the budget did not hold, if time is left
  large        Table 4.1's N = 8192 plain CG on cuBLAS 1 and 2 (the report's largest cells, a minute of GPU time)
  extras       our cells beyond the report's columns (cuBLAS --fused, MG-PCG), the GPU unit tests, every GPU
               configuration against float64, Table 4.3's other 32-step runs; then, if early, Table 4.5 with
               --overlap, racecheck and initcheck

The estimates are derived, not measured on a GPU node (none was at hand when the kit was written): CPU work from
this project's 2-core development machine scaled to 16 cores, GPU work from the bytes it streams at an attained
2.8 TB/s (80% of 3.5: an H100 SXM streams about 3 TB/s, an H200 about 4.3), CPU Poisson at 100 GB/s. The plan keeps
SLACK of the budget free; the driver measures the steps against their estimates as they run, defers the last ones
when it runs late and runs them after all when time is left."""
from pathlib import Path

from common import backend_facts
from gpukit import cases, plan_checks
from gpukit.checks import converged_and_agreed, gpu_tests_ran, poisson_converged, sanitizer_clean

PRESETS = ("paper", "ci")  # ci: the tiny cases, a smoke run of the kit in seconds
RESERVE_S = 10  # kept back for the summary and the archive
SLACK = 0.2  # the share of the budget the plan leaves free: its steps fit (1 - SLACK) * budget - RESERVE_S
BUDGET_S = 360  # 6 minutes: a lent GPU comes for 15 minutes in all, its start included, and a second try must fit
ROUNDS = 6  # a claim's pairs: the least count whose distribution-free 95% interval of a median exists (1 - 2/2^6)
BYTES_PER_S = 2.8e12
CPU_BYTES_PER_S = 100e9
CPU_POISSON_MAX_N = 2048  # plain CG on the node's CPU above this takes minutes: those cells are left to the clusters
PHASES = ("probe", "inputs", "tables", "claims", "targets", "memcheck", "claims-more", "large", "extras")
# Form factors (hemicube R = 256, the file's write included): room3 took 12.7 s on 2 threads here (docs/design-notes.md), room2
# has 1.77 times its patches and a row's cost grows with the patches in front of it.
FF_ESTIMATE_S = {"scene1.xml": 1, "scene2.xml": 2, "room3.xml": 4, "room2.xml": 12}
SCENE_ESTIMATE_S = {"scene1.xml": 1, "scene2.xml": 2, "room3.xml": 3, "room2.xml": 4}
# The GPU's lists beyond the report's lines (slurm/cases/report_cases.py): run after the tables, not in them.
BEYOND_LISTS = ("table43-steps32", "gpu-float16", "table45-overlap")


class Step:
    """A named piece of work: commands run one after the other, each judged by its exit status and its own checks;
    then `check`, if any, judges the records of all of them together (None: passed, else why not). `needs`: what
    of the node it uses beyond the GPU ('cublas', 'cusparse', 'sanitizer'), so that it is skipped, with the
    reason, where the node lacks it. `optional`: a step after the plan, run only when the steps before it ran early
    enough that it still ends within (1 - SLACK) of the budget. `prepare(driver)`, if any, returns the commands
    afresh just before the step runs (a round that depends on what an earlier round measured)."""

    def __init__(self, name, group, estimate_s, commands, check=None, optional=False, phase="extras", prepare=None):
        self.name, self.group, self.estimate_s, self.commands, self.check = name, group, estimate_s, commands, check
        self.optional = optional
        self.phase, self.prepare = phase, prepare
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
    it passed, else why not. A command with an `experiment` is recorded as repeat `repeat` of case `case_id`."""

    def __init__(self, argv, experiment=None, case_id=None, check=None, json_out=False, text_check=None, repeat=0):
        self.argv, self.experiment, self.case_id, self.check, self.json_out = argv, experiment, case_id, check, json_out
        self.text_check, self.repeat = text_check, repeat


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
    program, backend = Path(argv[0]).name, option(argv, "--backend")
    if program == "solve_tests":
        return out | {"cublas", "cusparse"}
    libraries = set(backend_facts.backends(program).get(backend, {}).get("libraries", ())) \
        if program in backend_facts.PROGRAMS else set()
    out |= libraries & {"cublas"}
    # cuSPARSE runs the csr float32 product in float (radiosity/solve/gpu/sparse_device.cuh)
    if "cusparse" in libraries and option(argv, "--storage") == "csr" and \
            option(argv, "--precision", "float") == "float" and option(argv, "--ff-precision", "float32") == "float32":
        out.add("cusparse")
    return out


def case_estimate(c):
    """Estimated seconds of one case, process start to exit: radiosity by its scene, loading F (room2: 1.17 GB)
    and the program's float64 check on 16 cores being most of it; Poisson from the bytes an iteration streams and
    iterations proportional to N (1581 at N = 1024, measured here), on the GPU or the node's CPU, plus a second for
    the process and the host-side checks."""
    t = c.line.split()
    if "poisson" in t[0]:
        n = int(option(t, "--n"))
        if option(t, "--precond") == "mg":
            # MG-PCG: 6-7 iterations at every N (measured on the CPU), each a V-cycle of about 40 vector passes
            # over all levels, and the host-side setup of b and u (3-5 s at N = 8192 on 2 cores here, less on 16)
            return round(2 + n * n / 8192 ** 2 + 8 * (6 + 40) * 8 * n * n / BYTES_PER_S)
        vectors = backend_facts.poisson_vectors(c.backend(), option(t, "--variant"), option(t, "--precision", "double"))
        rate = BYTES_PER_S if c.is_gpu() else CPU_BYTES_PER_S
        return max(1, round(1 + 1581 * n / 1024 * vectors * 8 * n * n / rate))
    return SCENE_ESTIMATE_S.get(Path(t[2]).name, 1 if "ci-" in c.line else 10)


def _n(c):
    return int(option(c.line.split(), "--n", 0))


def _plain(c):
    return option(c.line.split(), "--precond", "none") == "none"


def _scene(c):
    t = c.line.split()
    return Path(t[2]).name if len(t) > 2 and t[1] == "solve" else None


def companions(folder, preset):
    """The CPU cells on the node that the GPU claims set the GPU cells against (all OpenMP, on every core): Table 4.1's
    plain CG up to CPU_POISSON_MAX_N, Table 4.3's and Table 4.4's OpenMP."""
    folder, out = Path(folder), []
    for exp, keep in (("table41", lambda c: c.backend() == "openmp" and _plain(c) and _n(c) <= CPU_POISSON_MAX_N),
                      ("table43", lambda c: c.backend() == "openmp"),
                      ("table44", lambda c: c.backend() == "openmp")):
        f = folder / f"{exp}.txt"
        if f.exists():
            out += [c for c in cases.read(f, preset) if "ranks" not in c.prefixes and keep(c)]
    return out


def claim_groups(table_cases):
    """[(name, cases)]: the cells each claim compares, cheapest group first. Table 4.1 per N: cuBLAS 1 against
    cuBLAS 2 and the CPU against the GPU; per scene: CUDA with AOS (our kernels) against SOA (cuBLAS), and each
    against OpenMP on the same layout; Table 4.5: the hybrid at d = 0, 0.1 (the report's best) and 1 (the hybrid's
    best d of round 1 joins them when the round runs)."""
    groups = []
    for n in sorted({_n(c) for c in table_cases if c.experiment == "table41" and _plain(c)}):
        g = [c for c in table_cases if c.experiment == "table41" and _plain(c) and _n(c) == n]
        if len({c.is_gpu() for c in g}) == 2:
            groups.append((f"Table 4.1 at N = {n}: cuBLAS 1 against cuBLAS 2, the CPU against the GPU", g))
    for s in dict.fromkeys(_scene(c) for c in table_cases if c.experiment == "table43"):
        g = [c for c in table_cases if _scene(c) == s and (
            (c.experiment == "table43" and c.backend() in ("cuda", "openmp")) or
            (c.experiment == "table44" and c.backend() in ("cublas", "openmp") and "--fused" not in c.line))]
        if len(g) > 1:
            groups.append((f"{s}: CUDA AOS against SOA (cuBLAS), each against OpenMP", g))
    hybrid = [c for c in table_cases if c.experiment == "table45" and
              float(option(c.line.split(), "--distribution")) in (0.0, 0.1, 1.0)]
    if len(hybrid) > 1:
        groups.append(("Table 4.5: the hybrid at d = 0, 0.1, its best d and 1", hybrid))
    return sorted(groups, key=lambda g: sum(case_estimate(c) for c in g[1]))


def build(kit, tok, sanitizer, preset="paper", budget=BUDGET_S):
    """Every step, in the order of PHASES. `tok`: the case lists' tokens; `sanitizer`: compute-sanitizer's path or
    None. The form factors of scene 1 come first among the inputs: they are what runs where there is no GPU. The
    claim groups whose rounds fit the budget beside the other phases up to memcheck run in `claims`, cheapest
    first; the others in `claims-more`, after memcheck."""
    kit = Path(kit)
    b = lambda p: str(kit / "bin" / p)
    lists = kit / "cases" / preset

    def kit_argv(c):  # a case's command with the kit's binaries
        argv = c.argv(tok)
        return [b(argv[0].split("/")[-1])] + argv[1:]

    def case_cmd(c, repeat=0):
        check = poisson_converged if "poisson" in c.line.split()[0] else converged_and_agreed
        return Cmd(kit_argv(c), c.experiment, c.case_id, check, True, repeat=repeat)

    def case_step(c, phase, optional=False):
        return Step(f"{c.experiment} case {c.index}: {c.line}", c.experiment, case_estimate(c), [case_cmd(c)],
                    optional=optional, phase=phase)

    phase = {p: [] for p in PHASES}
    phase["probe"].append(Step("GPU triad and read sweep (bin/stream --device gpu)", "bandwidth", 5,
                               [Cmd([b("stream"), "--device", "gpu"], "gpu-stream", "kit/gpu-stream")], phase="probe"))
    for c in cases.read(lists / "formfactors.txt", preset):
        scene = Path(c.argv(tok)[2]).name
        phase["inputs"].append(Step(f"form factors of {scene}", "formfactors", FF_ESTIMATE_S.get(scene, 30),
                                    [Cmd(kit_argv(c))], phase="inputs"))  # CPU work: not recorded
    every = cases.gpu_cases(lists, preset)
    extra = [c for c in every if c.experiment in BEYOND_LISTS]
    gpu = [c for c in every if c not in extra]
    n_max = max((_n(c) for c in gpu if c.experiment == "table41"), default=0)
    large = [c for c in gpu if c.experiment == "table41" and _plain(c) and _n(c) == n_max]
    beyond = [c for c in gpu if "--fused" in c.line or not _plain(c)]  # ours, beyond the report's columns
    table_cases = [c for c in gpu if c not in large and c not in beyond] + companions(lists, preset)
    order = {"table43": 0, "table44": 1, "table45": 2, "table41": 3}
    table_cases.sort(key=lambda c: (order.get(c.experiment, 5), _n(c), c.experiment, c.index))
    phase["tables"] = [case_step(c, "tables") for c in table_cases]
    target = [c for c in large if c.backend() == "cuda"]
    scene4 = sorted((c for c in extra if c.experiment in ("table43-steps32", "gpu-float16") and "room2.xml" in c.line),
                    key=lambda c: BEYOND_LISTS.index(c.experiment))
    phase["targets"] = [case_step(c, "targets") for c in target + scene4]
    phase["large"] = [case_step(c, "large") for c in large if c not in target]
    memcheck, shared, initcheck = plan_checks.sanitizer_runs(kit, tok, preset)
    san = lambda tool, runs, est, ph, optional=False: [Step(
        f"compute-sanitizer {tool}: {name}", "sanitizer", est, [Cmd(
            [sanitizer or "compute-sanitizer", "--tool", tool, "--error-exitcode", "9", *argv, "--quiet"],
            text_check=sanitizer_clean)], optional=optional, phase=ph) for name, argv in runs.items()]
    phase["memcheck"] = san("memcheck", memcheck, 4, "memcheck")
    room = (1 - SLACK) * budget - RESERVE_S - sum(s.estimate_s for p in ("probe", "inputs", "tables", "targets",
                                                                         "memcheck") for s in phase[p])
    for name, group in claim_groups(table_cases):
        rounds = [round_step(name, group, r, case_cmd) for r in range(1, ROUNDS)]
        cost = sum(s.estimate_s for s in rounds)
        where = "claims" if cost <= room else "claims-more"
        room -= cost if where == "claims" else 0
        for s in rounds:
            s.phase = where
        phase[where] += rounds
    phase["extras"] = [case_step(c, "extras") for c in beyond]
    phase["extras"].append(Step("GPU unit tests (solve_tests --gtest_filter='Cuda*')", "correctness", 8,
                                [Cmd([b("solve_tests"), "--gtest_filter=Cuda*"], text_check=gpu_tests_ran)]))
    phase["extras"] += plan_checks.agreement_steps(kit, tok, preset, Step, Cmd)
    phase["extras"] += [case_step(c, "extras") for c in extra if c not in scene4 and c.experiment != "table45-overlap"]
    phase["extras"] += [case_step(c, "extras", True) for c in extra if c.experiment == "table45-overlap"]
    phase["extras"] += san("racecheck", shared, 6, "extras", True) + san("initcheck", initcheck, 4, "extras", True)
    return [s for p in PHASES for s in phase[p]]


def round_step(name, group, r, case_cmd):
    """Round r (1-based repeats after round 1, which is the tables' own) of one claim's group: its cases side by
    side, in the list's order on even rounds and reversed on odd ones. Table 4.5's group adds, when the round runs,
    the d that was fastest in round 1 (from the records made so far)."""
    ordered = lambda g: g if r % 2 == 0 else list(reversed(g))
    hybrid = group[0].experiment == "table45"
    prepare = (lambda driver: [case_cmd(c, r) for c in ordered(group + best_hybrid(driver, group))]) if hybrid else None
    return Step(f"claims round {r + 1} of {ROUNDS}: {name}", "claims", sum(case_estimate(c) for c in group) +
                (SCENE_ESTIMATE_S["room2.xml"] if prepare else 0), [case_cmd(c, r) for c in ordered(group)],
                phase="claims", prepare=prepare)


def best_hybrid(driver, group):
    """[the table45 case whose round-1 run was fastest among those not in `group`], or [] (none counted yet)."""
    from gpukit.checks import converged_and_agreed as ok
    best, t_best = None, None
    for rec in driver.read_records("table45"):
        env = rec.get("provenance", {}).get("env", {})
        t = rec.get("times_s", {})
        if env.get("HPCGI_REPEAT") != "0" or ok(rec) is not None or not isinstance(t.get("solve"), (int, float)):
            continue
        total = t.get("setup", 0) + t["solve"] + (t.get("upload") or 0)
        if t_best is None or total < t_best:
            best, t_best = env.get("HPCGI_CASE"), total
    kit_cases = cases.read(Path(driver.kit) / "cases" / driver.preset / "table45.txt", driver.preset)
    return [c for c in kit_cases if c.case_id == best and c not in group]


def fitting(steps, budget):
    """{step name: 'run' | 'if time' | 'if early'}: 'run' for the steps that fit (1 - SLACK) of the budget less the
    reserve, in order; 'if time' for the later ones the driver runs when the measured pace leaves room; 'if early'
    for the optional ones."""
    total, room, out, full = 0, (1 - SLACK) * budget - RESERVE_S, {}, False
    for s in steps:  # in order, as the driver runs them: after the first that does not fit, none is planned
        full = full or s.optional or total + s.estimate_s > room
        total += 0 if full else s.estimate_s
        out[s.name] = "if early" if s.optional else "if time" if full else "run"
    return out


def print_plan(steps, budget):
    """The plan, every step with its phase and estimated seconds, and what is expected to run. Returns the seconds
    of 'run'."""
    what = fitting(steps, budget)
    room = (1 - SLACK) * budget - RESERVE_S
    total = sum(s.estimate_s for s in steps if what[s.name] == "run")
    print(f"gpu-kit plan: {len(steps)} steps, budget {budget:.0f} s ({RESERVE_S} s kept for the summary and the "
          f"archive, {SLACK:.0%} as slack); estimated seconds on an H100/H200 node with 16 cores; phases in order: "
          f"{', '.join(PHASES)}")
    for s in steps:
        print(f"  {s.estimate_s:5d} s  {what[s.name]:9s} {s.phase:11s} [{s.group}] {s.name}")
    later = sum(s.estimate_s for s in steps if what[s.name] != "run")
    print(f"  total of the steps that fit: {total} s of {room:.0f} s ({total / 60:.1f} min; the budget with its slack "
          f"and reserve {budget:.0f} s = {budget / 60:.1f} min; {later} s more if time is left)")
    return total
