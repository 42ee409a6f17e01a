#!/usr/bin/env python3
"""gpu-kit/run: the GPU half of the study on a bare GPU node, in one command, within a budget.

    gpu-kit/run [--dry-run] [--out DIR] [--budget S]      (env: BUDGET_S, OUT, RRV_SCENES, MACHINE, CUDA_HOME)

From wherever the kit lies, with a clean environment (python3 and the node's CUDA driver; cuBLAS 13 from the CUDA
toolkit's lib64 or the nvidia-cublas Python package, whichever is found first, and it says which): the form factors
of scenes 1-4 on the node's CPUs, then the steps below, most important first, each checked against what is left
of the budget (default 420 s) and skipped by name when its estimate does not fit, never cut off half-way:
  bandwidth    the GPU's triad and read-only sweep (bin/stream --device gpu): the limit every GPU number is judged by
  correctness  the GPU unit tests; compute-sanitizer memcheck on every CUDA backend of both programs, racecheck and
               initcheck on every kernel that uses shared memory; every GPU backend against float64 on scenes 1-2
               (the program's own check) and against the CPU on Poisson N = 256 and 1024
  cases        the GPU cases of the paper preset's case lists (Tables 4.1, 4.3, 4.4, 4.5), read from the lists;
               Table 4.5 again with --overlap, Tables 4.3/4.4 again with RRV's 32 fixed steps
(The GPU integration tests travel too, for a longer session: python3 -m pytest -c pytest.ini tests/integration.)
Everything is written under the output folder (default ./gpu-kit-out): records in results/<label>/<experiment>/
paper.jsonl, results/<label>/machine.json, logs/, summary.md, and one archive gpu-kit-<label>.tar.gz (<= 16 MiB)
for `make gpu-import ARCHIVE=...` at home. The estimates are for an H100/H200 node with 16 cores.

Exit status: 0 when every step that ran passed; 1 when one failed; 3 without a usable GPU (one line says so, after
the CPU steps that need none: the form factors of scene 1); 2 for bad arguments."""
import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import tarfile
import time
from pathlib import Path

KIT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(KIT))
from gpukit import cases, libs, summary  # noqa: E402
from common import machine_label  # noqa: E402

PRESET = "paper"
ARCHIVE_LIMIT = 16 << 20
RESERVE_S = 10  # kept back for the summary and the archive

# The estimates are derived, not measured on a GPU node (none was at hand when the kit was written): CPU work from
# this project's 2-core development machine scaled to 16 cores, GPU work from the bytes it streams at 3.5 TB/s
# (an H100 SXM streams about 3, an H200 about 4.3). The budget is what protects the wall clock: a step runs only
# when its estimate fits what is left, and its commands are stopped at what is left.
# Form factors (hemicube R = 256, the file's write included): room3 took about 13 s on 2 threads here (results/vm-amd-epyc-2c/room3_pipeline/vm.jsonl), room2
# has 1.77 times its patches and a row's cost grows with the patches in front of it.
FF_ESTIMATE_S = {"scene1.xml": 1, "scene2.xml": 2, "room3.xml": 4, "room2.xml": 12}


class Step:
    """A named piece of work: commands run one after the other, each judged by its exit status and its own checks;
    then `check`, if any, judges the records of all of them together (None: passed, else why not)."""

    def __init__(self, name, group, estimate_s, commands, check=None):
        self.name, self.group, self.estimate_s, self.commands, self.check = name, group, estimate_s, commands, check


class Cmd:
    """One command. `check` judges the record it prints (--json), `text_check` its output; each returns None when
    it passed, else why not."""

    def __init__(self, argv, experiment=None, case_id=None, check=None, json_out=False, text_check=None):
        self.argv, self.experiment, self.case_id, self.check, self.json_out = argv, experiment, case_id, check, json_out
        self.text_check = text_check


# --- what a run must show -----------------------------------------------------------------------------------------
def converged_and_agreed(rec):
    """A radiosity record counts when it converged (or ran its fixed steps) and agreed with float64."""
    r, v = rec.get("result", {}), rec.get("verify") or {}
    if r.get("status") not in ("converged", "steps_done"):
        return f"status {r.get('status')} ({r.get('detail', '')})"
    if v.get("agreed") is not True:
        return f"disagrees with the float64 reference (max rel diff {v.get('max_rel_diff')}, bound {v.get('bound')})"
    return None


def poisson_converged(rec):
    r = rec.get("result", {})
    if r.get("converged") is not True:
        return f"did not converge: status {r.get('status')} after {r.get('iterations')} iterations"
    return None


def poisson_agree(recs):
    """The GPU backends against the first record (openmp): iterations within 1, max |u - u_h| to 4 digits."""
    ref, bad = recs[0]["result"], []
    for r in recs[1:]:
        name = r["params"]["backend"] + ("" if r["params"].get("variant") in (None, "onesweep") else
                                         " " + r["params"]["variant"])
        it, e = r["result"]["iterations"], r["result"]["error_inf"]
        if abs(it - ref["iterations"]) > 1:
            bad.append(f"{name}: {it} iterations, openmp {ref['iterations']}")
        if not abs(e - ref["error_inf"]) <= 5e-4 * abs(ref["error_inf"]):
            bad.append(f"{name}: error {e:.6g}, openmp {ref['error_inf']:.6g} (not the same to 4 digits)")
    return "; ".join(bad) or None


def gpu_tests_ran(text):
    """The GPU unit tests must have run, not skipped for want of a GPU."""
    return "skipped: the GPU backends cannot run here" if "the GPU backends cannot run here" in text else None


def sanitizer_clean(text):
    """compute-sanitizer's own summary: no error (memcheck, initcheck), no hazard (racecheck)."""
    if "ERROR SUMMARY: 0 errors" in text or "RACECHECK SUMMARY: 0 hazards" in text:
        return None
    found = [l.strip("= ").strip() for l in text.splitlines() if "SUMMARY" in l]
    return "compute-sanitizer: " + ("; ".join(found) if found else "no summary line")


class Driver:
    def __init__(self, a):
        self.a = a
        self.out = Path(a.out).resolve()
        self.t0 = time.monotonic()
        self.budget = a.budget
        self.failed, self.skipped, self.done = [], [], []
        self.label = None
        self.env = None

    # --- paths and environment ---
    def left(self):
        return self.budget - (time.monotonic() - self.t0)

    def say(self, msg):
        line = f"gpu-kit [{time.monotonic() - self.t0:5.0f} s]: {msg}"
        print(line, flush=True)
        if self.out.exists():
            with open(self.out / "logs" / "progress.log", "a") as f:
                f.write(line + "\n")

    def rrv(self):
        return Path(os.environ.get("RRV_SCENES") or KIT / "scenes" / "rrv").resolve()

    def tokens(self):
        return {"FF_DIR": self.out / "ff", "RRV_SCENES": self.rrv(), "PRESET": PRESET,
                "RESULTS": self.out / "results" / (self.label or "unknown")}

    def records(self, experiment):
        return self.out / "results" / self.label / experiment / f"{PRESET}.jsonl"

    def child_env(self, cublas_dir):
        env = {k: v for k, v in os.environ.items() if not k.startswith("HPCGI_")}
        env["LD_LIBRARY_PATH"] = os.pathsep.join([str(KIT / "lib")] + ([cublas_dir] if cublas_dir else []))
        env["TMPDIR"] = str(self.out / "tmp")  # nothing is written outside the output folder
        env["PYTHONDONTWRITEBYTECODE"] = "1"
        env["RRV_SCENES"] = str(self.rrv())
        env.setdefault("OMP_PROC_BIND", "close")
        return env

    # --- the plan ---
    def plan(self):
        tok = self.tokens()
        b = lambda p: str(KIT / "bin" / p)
        ffcases = [c for c in cases.read(KIT / "cases" / PRESET / "formfactors.txt")]
        gpu = cases.gpu_cases(KIT / "cases" / PRESET)
        steps = []

        def kit_argv(c):  # a case's command with the kit's binaries
            argv = c.argv(tok)
            return [b(argv[0].split("/")[-1])] + argv[1:]

        # Form factors first (CPU), scene 1 before all: it is what runs where there is no GPU.
        for c in ffcases:
            scene = Path(c.argv(tok)[2]).name
            steps.append(Step(f"form factors of {scene}", "formfactors", FF_ESTIMATE_S.get(scene, 30),
                              [Cmd(kit_argv(c))]))  # CPU work: not recorded (the archive holds GPU records)
        ff1 = self.out / "ff" / "paper-scene1.ff"
        ff2 = self.out / "ff" / "paper-scene2.ff"
        scene = lambda k: str(KIT / "radiosity" / "scenes" / f"scene{k}.xml")
        # Bandwidth: the limit every GPU number is judged by.
        steps.append(Step("GPU triad and read sweep (bin/stream --device gpu)", "bandwidth", 5,
                          [Cmd([b("stream"), "--device", "gpu"], "gpu-stream", "kit/gpu-stream")]))
        # Correctness.
        steps.append(Step("GPU unit tests (solve_tests --gtest_filter='Cuda*')", "correctness", 8,
                          [Cmd([b("solve_tests"), "--gtest_filter=Cuda*"], text_check=gpu_tests_ran)]))
        san = self.sanitizer()
        s1 = [b("radiosity"), "solve", scene(1), "--ff", str(ff1), "--no-verify"]
        s1d = s1 + ["--storage", "dense"]  # the dense kernels (--storage auto takes a sparse one on cuda, cublas)
        memcheck = {
            "radiosity cuda float": s1d + ["--backend", "cuda", "--steps", "3"],
            "radiosity cuda double bicgstab": s1d + ["--backend", "cuda", "--precision", "double", "--method",
                                                    "bicgstab", "--tol", "1e-5"],
            "radiosity cublas bicgstab": s1d + ["--backend", "cublas", "--method", "bicgstab", "--tol", "1e-5"],
            "radiosity cublas --fused double": s1d + ["--backend", "cublas", "--fused", "--precision", "double",
                                                     "--steps", "3"],
            "radiosity cuda compressed float16": s1 + ["--backend", "cuda", "--storage", "compressed",
                                                       "--ff-precision", "float16", "--steps", "3"],
            "radiosity hybrid 0.3": s1d + ["--backend", "hybrid", "--distribution", "0.3", "--steps", "3"],
            "radiosity hybrid 0.3 --overlap": s1d + ["--backend", "hybrid", "--distribution", "0.3", "--overlap",
                                                    "--steps", "3"],
            "poisson cublas1 N=64": [b("poisson"), "--backend", "cublas1", "--n", "64"],
            "poisson cublas2 N=64": [b("poisson"), "--backend", "cublas2", "--n", "64"],
            "poisson cuda one-sweep N=64": [b("poisson"), "--backend", "cuda", "--n", "64"],
            "poisson cuda classic N=64": [b("poisson"), "--backend", "cuda", "--variant", "classic", "--n", "64"],
            "stream --device gpu": [b("stream"), "--device", "gpu", "--size", "1048576", "--trials", "2"],
        }
        # Shared memory: the radiosity AOS tiles and block sums (cuda; hybrid runs the same kernels), Poisson's
        # one-sweep rings and block sums at N = 300 (partial tiles in both directions), its classic dots, stream's.
        shared = {
            "radiosity cuda (tiles, block sums)": s1d + ["--backend", "cuda", "--steps", "2"],
            "poisson cuda one-sweep N=300": [b("poisson"), "--backend", "cuda", "--n", "300", "--max-iter", "4"],
            "poisson cuda classic N=300": [b("poisson"), "--backend", "cuda", "--variant", "classic", "--n", "300",
                                           "--max-iter", "4"],
            "stream --device gpu": [b("stream"), "--device", "gpu", "--size", "1048576", "--trials", "2"],
        }
        tools = [("memcheck", memcheck, 4), ("racecheck", shared, 6), ("initcheck", shared, 4)]
        for tool, runs, est in tools:
            for name, argv in runs.items():
                steps.append(Step(f"compute-sanitizer {tool}: {name}", "correctness", est,
                                  [Cmd([san or "compute-sanitizer", "--tool", tool, "--error-exitcode", "9",
                                        *argv, "--quiet"], text_check=sanitizer_clean)]))
        # Every GPU configuration against float64 on scenes 1 and 2 (the program's check, verify.agreed).
        dense = ["--storage", "dense"]
        configs = {"cuda": ["--backend", "cuda", *dense], "cuda double": ["--backend", "cuda", "--precision", "double", *dense],
                   "cublas": ["--backend", "cublas", *dense], "cublas --fused": ["--backend", "cublas", "--fused", *dense],
                   "hybrid 0": ["--backend", "hybrid", "--distribution", "0"],
                   "hybrid 0.3": ["--backend", "hybrid", "--distribution", "0.3"],
                   "hybrid 0.3 --overlap": ["--backend", "hybrid", "--distribution", "0.3", "--overlap"],
                   "hybrid 1": ["--backend", "hybrid", "--distribution", "1"]}
        # the sparse storages on scene 1 (the budget holds no more): cuSPARSE for csr float32, our warp-per-row
        # kernel for compressed
        sparse = {"cuda csr": ["--backend", "cuda", "--storage", "csr"],
                  "cuda compressed": ["--backend", "cuda", "--storage", "compressed"],
                  "cublas csr": ["--backend", "cublas", "--storage", "csr"]}
        for k, ff, est in ((1, ff1, 12), (2, ff2, 16)):  # about 1 s a configuration on scene 1, 2 s on scene 2
            steps.append(Step(f"every GPU backend against float64 on scene {k}", "correctness", est,
                              [Cmd([b("radiosity"), "solve", scene(k), "--ff", str(ff), "--tol", "1e-6", *args],
                                   "gpu-correctness", f"kit/agree/scene{k}/{name}", converged_and_agreed, True)
                               for name, args in {**configs, **(sparse if k == 1 else {})}.items()]))
        for n, est in ((256, 5), (1024, 8)):
            steps.append(Step(f"Poisson GPU backends against the CPU at N = {n}", "correctness", est,
                              [Cmd([b("poisson"), "--backend", be, *extra, "--n", str(n)],
                                   None if be == "openmp" else "gpu-correctness",
                                   f"kit/poisson-agree/{n}/{be}{'-'.join([''] + extra[1:])}", poisson_converged, True)
                               for be, extra in (("openmp", []), ("cublas1", []), ("cublas2", []), ("cuda", []),
                                                 ("cuda", ["--variant", "classic"]))], poisson_agree))
        # The report's GPU cases, from the case lists.
        for c in gpu:
            argv = kit_argv(c)
            check = poisson_converged if "poisson" in argv[0] else converged_and_agreed
            steps.append(Step(f"{c.experiment} case {c.index}: {c.line}", c.experiment, case_estimate(c),
                              [Cmd(argv, c.experiment, c.case_id, check, True)]))
        # Derived from the same lines: Table 4.5 with --overlap (not at d = 0 and 1, where nothing is copied and
        # --overlap changes nothing: radiosity/solve/gpu/hybrid.cu), Tables 4.3/4.4 with RRV's 32 fixed steps.
        for c in gpu:
            if c.experiment == "table45" and not any(c.line.endswith(e) for e in ("--distribution 0.0",
                                                                                  "--distribution 1.0")):
                d = cases.Case("table45-overlap", c.index, c.line + " --overlap")
            elif c.experiment in ("table43", "table44") and "--tol 1e-6" in c.line:
                d = cases.Case(c.experiment + "-steps32", c.index, c.line.replace("--tol 1e-6", "--steps 32"))
            else:
                continue
            steps.append(Step(f"{d.experiment} case {d.index}: {d.line}", d.experiment, case_estimate(d),
                              [Cmd(kit_argv(d), d.experiment, d.case_id, converged_and_agreed, True)]))
        return steps

    def sanitizer(self):
        for c in (shutil.which("compute-sanitizer", path=os.environ.get("PATH", "")),
                  os.path.join(os.environ.get("CUDA_HOME", "/usr/local/cuda"), "bin", "compute-sanitizer"),
                  "/usr/local/cuda/bin/compute-sanitizer", "/usr/local/cuda/compute-sanitizer/compute-sanitizer"):
            if c and os.access(c, os.X_OK):
                return c
        return None

    # --- running ---
    def run_cmd(self, step, cmd, log):
        argv = list(cmd.argv)
        env = dict(self.env)
        if Path(argv[0]).name in ("poisson", "radiosity", "stream"):
            argv.append("--quiet")
            if cmd.json_out:
                argv.append("--json")
        if cmd.experiment:  # only GPU runs are recorded: every record of the archive carries its GPU
            rec = self.records(cmd.experiment)
            rec.parent.mkdir(parents=True, exist_ok=True)
            argv += ["--record", str(rec)]
            env.update(HPCGI_EXPERIMENT=cmd.experiment, HPCGI_PRESET=PRESET, HPCGI_CASE=cmd.case_id or "",
                       HPCGI_REPEAT="0")
        limit = max(1.0, self.left() - RESERVE_S)
        with open(log, "a") as f:
            f.write("$ " + " ".join(argv) + "\n")
            f.flush()
            try:
                p = run_group(argv, env, limit)
            except subprocess.TimeoutExpired:
                return f"ran past what was left of the budget ({limit:.0f} s): stopped", None
            except OSError as e:
                return f"cannot run {argv[0]}: {e}", None
            f.write(p.stdout)
        lines = [l for l in p.stdout.splitlines() if l.startswith("{")]
        rec = json.loads(lines[-1]) if lines and cmd.json_out else None
        if p.returncode != 0:
            return f"exit {p.returncode}: " + (p.stdout.strip().splitlines() or [""])[-1][:300], rec
        if cmd.text_check and cmd.text_check(p.stdout):
            return cmd.text_check(p.stdout), rec
        if cmd.check:
            return ("printed no record", None) if rec is None else (cmd.check(rec), rec)
        return None, rec

    def run_step(self, step):
        if self.left() - RESERVE_S < step.estimate_s:
            self.say(f"SKIPPED {step.name}: {self.left() - RESERVE_S:.0f} s left, it needs about {step.estimate_s} s")
            self.skipped.append(step.name)
            return False
        if step.commands and step.commands[0].argv[0] == "compute-sanitizer":  # not found
            self.say(f"SKIPPED {step.name}: compute-sanitizer not found (PATH, $CUDA_HOME/bin, /usr/local/cuda)")
            self.skipped.append(step.name)
            return False
        product = step.commands[0].argv[step.commands[0].argv.index("-o") + 1] \
            if step.group == "formfactors" and "-o" in step.commands[0].argv else None
        if product and Path(product).is_file():  # a second run into the same folder: the solves check its header
            self.done.append((step.name, 0.0, step.estimate_s))
            self.say(f"ok {step.name}: {Path(product).name} already made")
            return True
        t = time.monotonic()
        log = self.out / "logs" / f"{step.group}.log"
        bad, recs = [], []
        for cmd in step.commands:
            why, rec = self.run_cmd(step, cmd, log)
            recs.append(rec)
            if why:
                bad.append(f"{' '.join(Path(x).name if '/' in x else x for x in cmd.argv[:8])}: {why}")
        if not bad and step.check:
            why = step.check(recs)
            if why:
                bad.append(why)
        if bad:
            self.failed.append(f"{step.name}: " + "; ".join(bad))
            self.say(f"FAILED {step.name} ({time.monotonic() - t:.1f} s): " + "; ".join(bad) +
                     f" (see logs/{log.name})")
            return False
        self.done.append((step.name, time.monotonic() - t, step.estimate_s))
        self.say(f"ok {step.name} ({time.monotonic() - t:.1f} s, estimated {step.estimate_s} s)")
        return True

    def probe_gpu(self):
        """None when a CUDA backend runs here; else why not. Only exit 2 with 'needs an NVIDIA GPU' means absent:
        any other failure is a failure of the GPU code, reported as such and not taken for a missing GPU."""
        p = subprocess.run([str(KIT / "bin" / "poisson"), "--backend", "cuda", "--n", "4", "--quiet"], cwd=KIT,
                           env=self.env, capture_output=True, text=True, timeout=120)
        if p.returncode == 0:
            return None, None
        if p.returncode == 2 and "needs an NVIDIA GPU" in p.stderr:
            return "absent", p.stderr.strip()
        return "broken", f"bin/poisson --backend cuda --n 4 exited {p.returncode}: {p.stderr.strip()}"


def run_group(argv, env, limit):
    """subprocess.run in a process group of its own, the whole group killed at the time limit (compute-sanitizer
    runs the program as its child, which a plain timeout would leave running)."""
    p = subprocess.Popen(argv, cwd=KIT, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                         errors="replace", start_new_session=True)
    try:
        out, _ = p.communicate(timeout=limit)
    except subprocess.TimeoutExpired:
        try:
            os.killpg(p.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        p.communicate()
        raise
    return subprocess.CompletedProcess(argv, p.returncode, out)


def case_estimate(c):
    """Estimated seconds of one GPU case on an H100/H200 node, process start to exit (see FF_ESTIMATE_S): radiosity
    by its scene, loading F (room2: 1.17 GB) and the program's float64 check on 16 cores being most of it; Poisson
    from the bytes an iteration streams at 3.5 TB/s and iterations proportional to N (1581 at N = 1024, measured
    here), plus a second for the process and the host-side checks."""
    t = c.line.split()
    if "poisson" in t[0]:
        n = int(t[t.index("--n") + 1])
        vectors = {"cublas1": 14, "cublas2": 16, "cuda": 6}[c.backend()]
        iterations = 1581 * n / 1024
        if "--precond" in t and t[t.index("--precond") + 1] == "mg":
            # MG-PCG: 6-7 iterations at every N (measured on the CPU), each a V-cycle of about 40 vector passes
            # over all levels (smoothing both colours before and after, residual, restriction, prolongation), and
            # the host-side setup of b and u (3-5 s at N = 8192 on 2 cores here, less on 16)
            iterations, vectors = 8, 6 + 40
            return round(2 + n * n / 8192 ** 2 + iterations * vectors * 8 * n * n / 3.5e12)
        return round(1 + iterations * vectors * 8 * n * n / 3.5e12)
    scene = Path(t[2]).name
    return {"scene1.xml": 1, "scene2.xml": 2, "room3.xml": 3, "room2.xml": 4}.get(scene, 10)


def print_plan(steps, budget):
    total, rows = 0, []
    for s in steps:
        fits = total + s.estimate_s <= budget - RESERVE_S
        if fits:
            total += s.estimate_s
        rows.append((s.group, s.name, s.estimate_s, "run" if fits else "skip (budget)"))
    print(f"gpu-kit plan: {len(steps)} steps, budget {budget:.0f} s ({RESERVE_S} s kept for the summary and the "
          f"archive); estimated seconds on an H100/H200 node with 16 cores")
    for g, n, e, what in rows:
        print(f"  {e:5d} s  {what:14s} [{g}] {n}")
    print(f"  total of the steps that fit: {total} s of {budget - RESERVE_S:.0f} s")
    return total


def main(argv=None):
    ap = argparse.ArgumentParser(prog="gpu-kit/run", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dry-run", action="store_true", help="print the plan (steps, estimated seconds) and exit")
    ap.add_argument("--json", action="store_true", help="with --dry-run: the plan as JSON")
    ap.add_argument("--out", default=os.environ.get("OUT", "gpu-kit-out"), help="output folder (default ./gpu-kit-out)")
    ap.add_argument("--budget", type=float, default=None, help="seconds for the whole run (default BUDGET_S or 420)")
    a = ap.parse_args(argv)
    if a.budget is None:
        try:
            a.budget = float(os.environ.get("BUDGET_S", "420"))
        except ValueError:
            print(f"gpu-kit/run: BUDGET_S={os.environ['BUDGET_S']!r} is no number of seconds", file=sys.stderr)
            return 2
    if not a.budget > RESERVE_S:
        print(f"gpu-kit/run: the budget must exceed {RESERVE_S} s, got {a.budget:g}", file=sys.stderr)
        return 2
    d = Driver(a)
    try:
        d.label = machine_label.describe()["label"]
    except ValueError as e:
        print(f"gpu-kit/run: {e}", file=sys.stderr)
        return 2
    steps = d.plan()
    if a.dry_run:
        if a.json:
            gpu = [{"experiment": c.experiment, "index": c.index, "line": c.line}
                   for c in cases.gpu_cases(KIT / "cases" / PRESET)]
            print(json.dumps({"budget_s": a.budget, "reserve_s": RESERVE_S, "gpu_cases": gpu,
                              "steps": [{"name": s.name, "group": s.group, "estimate_s": s.estimate_s}
                                        for s in steps]}))
        else:
            print_plan(steps, a.budget)
        return 0
    return run(d, steps)


def run(d, steps):
    out = d.out
    for sub in ("logs", "tmp", "ff"):
        (out / sub).mkdir(parents=True, exist_ok=True)
    cublas_dir, how = libs.find_cublas()
    d.env = d.child_env(cublas_dir)
    print_plan(steps, d.budget)
    if cublas_dir:
        d.say(f"cuBLAS 13 from {how}")
    else:
        d.say(f"no cuBLAS 13 found ({how}): the programs cannot start")
        print("gpu-kit: no GPU usable: cuBLAS 13 and cuSPARSE (" + ", ".join(libs.CUBLAS_SONAMES) + ") not found; set CUDA_HOME",
              file=sys.stderr)
        return 3
    bad = {b.name: libs.problems(b, KIT, d.env) for b in sorted((KIT / "bin").iterdir())}
    bad = {k: v for k, v in bad.items() if v}
    if bad:
        print("gpu-kit: the kit's libraries do not resolve here: " + "; ".join(f"{k}: {', '.join(v)}"
                                                                             for k, v in bad.items()), file=sys.stderr)
        return 1
    machine = machine_label.describe()
    (out / "results" / d.label).mkdir(parents=True, exist_ok=True)
    smi = shutil.which("nvidia-smi")
    if smi:
        q = subprocess.run([smi, "-q"], capture_output=True, text=True, timeout=60)
        (out / "logs" / "nvidia-smi-q.txt").write_text(q.stdout + q.stderr)
        machine["nvidia_smi"] = nvidia_smi_fields(smi)
    machine["kit"] = json.loads((KIT / "KIT-MANIFEST.json").read_text()).get("git_commit") \
        if (KIT / "KIT-MANIFEST.json").exists() else None
    machine["cublas"] = {"folder": cublas_dir, "found_in": how}
    (out / "results" / d.label / "machine.json").write_text(json.dumps(machine, indent=1) + "\n")
    state, why = d.probe_gpu()
    if state == "broken":
        d.failed.append(f"GPU probe: {why}")
        d.say(f"FAILED GPU probe (a GPU answered, but the cuda backend failed; going on): {why}")
    ff = [s for s in steps if s.group == "formfactors"]
    d.run_step(ff[0])  # scene 1: needs no GPU
    if state == "absent":
        print(f"gpu-kit: no GPU: {why}; ran only what needs none (the plan, the form factors of scene 1)",
              file=sys.stderr)
        return 3
    for s in ff[1:] + [s for s in steps if s.group != "formfactors"]:
        d.run_step(s)
    try:
        text = summary.write(out / "results" / d.label, KIT / "paper", d)
    except Exception as e:  # the archive must still be made: the records are what counts
        import traceback
        d.failed.append(f"summary: {type(e).__name__}: {e}")
        text = "# GPU kit summary\n\nThe summary failed:\n\n```\n" + traceback.format_exc() + "```\n"
    (out / "summary.md").write_text(text)
    archive = pack_archive(out, d.label)
    d.say(f"archive {archive} ({archive.stat().st_size / 2**20:.2f} MiB): bring it home, then "
          f"make gpu-import ARCHIVE={archive.name}")
    print(text)
    return 1 if d.failed else 0


def nvidia_smi_fields(smi):
    fields = "name,driver_version,memory.total,clocks.max.sm,clocks.max.mem,clocks.sm,clocks.mem,power.limit," \
             "pci.bus_id,compute_mode"
    q = subprocess.run([smi, f"--query-gpu={fields}", "--format=csv,noheader"], capture_output=True, text=True,
                       timeout=60)
    return [dict(zip(fields.split(","), [v.strip() for v in l.split(",")])) for l in q.stdout.splitlines() if l]


def pack_archive(out, label):
    """out/gpu-kit-<label>.tar.gz: the records, the logs and the summary; logs cut to their ends if it would be
    over 16 MiB."""
    archive = out / f"gpu-kit-{label}.tar.gz"
    members = [("results/" + label, out / "results" / label), ("summary.md", out / "summary.md")]
    logs = sorted((out / "logs").iterdir(), key=lambda p: p.stat().st_size)
    for cut in (None, 1 << 20, 64 << 10):
        with tarfile.open(archive, "w:gz") as t:
            for name, path in members:
                t.add(path, arcname=name)
            for log in logs:
                if cut is None or log.stat().st_size <= cut:
                    t.add(log, arcname="logs/" + log.name)
                else:
                    data = log.read_bytes()[-cut:]
                    info = tarfile.TarInfo("logs/" + log.name)
                    info.size, info.mtime = len(data), int(time.time())
                    import io
                    t.addfile(info, io.BytesIO(data))
        if archive.stat().st_size <= ARCHIVE_LIMIT:
            return archive
    return archive


if __name__ == "__main__":
    sys.exit(main())
