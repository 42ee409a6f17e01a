#!/usr/bin/env python3
"""gpu-kit/run: the GPU half of the study on a bare GPU node, in one command, within a budget.

    gpu-kit/run [--dry-run] [--out DIR] [--budget S] [--preset paper|ci]
                (env: BUDGET_S, RRV_SCENES, MACHINE, CUDA_HOME)

On a lent machine whose output folder comes back with few files, run gpu-kit/device-run instead: it runs this with
its work files elsewhere and leaves only what comes back (gpukit/device_run.py).

From wherever the kit lies, with the node's environment, to which it adds (LD_LIBRARY_PATH keeps the node's
folders, after the kit's lib/): python3, the node's CUDA driver, and cuBLAS 13, cuSPARSE 12 and nvJitLink 13
from the node (the loader's search, then the CUDA toolkit's lib64 or the nvidia CUDA Python packages). Its first
lines say what it found: the driver (libcuda.so.1, from where), each library (what is missing, named), the GPU and
compute-sanitizer. Then the plan (gpukit/plan.py), in the order that keeps what matters when time runs short:
  probe      the GPU's triad and read-only sweep (bin/stream --device gpu): the limit every GPU number is judged by
  inputs     the form factors of the preset's scenes on the node's CPUs
  tables     every GPU cell of Tables 4.1 (N = 8192's plain CG aside), 4.3, 4.4, 4.5 once, read from the case lists,
             with the OpenMP cells on the node's cores that the GPU claims compare them with
  claims     rounds 2-6 of each claim's cells, side by side, their order alternating (paired, interleaved runs)
  targets    Poisson plain CG at N = 8192 on cuda, scene 4's 32 Jacobi steps with float32 and float16 F
  large      Table 4.1's N = 8192 plain CG on cuBLAS 1 and 2
  memcheck   compute-sanitizer memcheck on every CUDA backend of both programs
  extras     the GPU unit tests, every GPU configuration against float64, the other 32-step runs; if early,
             Table 4.5 with --overlap, racecheck and initcheck
each with its estimated seconds. The plan fits 80% of the budget (default 360 s); the driver, measuring the steps
against their estimates as they run, defers the last ones when it runs late and runs them after all if time is left.
Beside every recorded run it samples the GPU (clocks, temperature, power, throttle reasons: gpukit/gpu_state.py)
before and after, into the experiment's state file; a run during a thermal or hardware slowdown is flagged disturbed.
A step the node cannot run is skipped with the reason: the sanitizer's where it refuses the device (as under
gVisor), the cuBLAS (cuSPARSE) ones without cuBLAS (cuSPARSE). A skip is never counted as a failure.
Everything is written under the output folder (default ./gpu-kit-out; never $OUT by itself): records in
results/<label>/<experiment>/<preset>.jsonl with their state files, results/<label>/machine.json
(common/machine_label.py --json), logs/, summary.md (every step with its estimate and its time), and one archive
gpu-kit-<label>.tar.gz (<= 16 MiB) for `make gpu-import ARCHIVE=...` at home. The summary and the archive are
written whatever fails, the driver's own death and SIGTERM included.

Exit status: 0 every step ran and passed; 1 a step failed or disagreed (or the driver itself failed); 3 no GPU at
all (after the CPU step that needs none: the form factors of scene 1); 6 none failed, but some were skipped (for
want of time, a library or a tool); 2 bad arguments."""
import argparse
import json
import os
import signal
import subprocess
import sys
import time
import traceback
from pathlib import Path

KIT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(KIT))
from gpukit import cases, gpu_state, node, plan, probe, summary  # noqa: E402
from gpukit.children import run_group, signal_name  # noqa: E402
from gpukit.archive import pack_archive  # noqa: E402,F401  (the tests pack fake outputs through it)
from gpukit.plan import BUDGET_S, PRESETS, RESERVE_S, SLACK, Outcome  # noqa: E402
from common import machine_label  # noqa: E402

from gpukit.node import EXIT_FAILED, EXIT_NO_GPU, EXIT_OK, EXIT_SKIPPED, EXIT_USAGE  # noqa: E402


class Stopped(Exception):
    """The driver was told to stop (SIGTERM, SIGHUP): the summary and the archive are still written."""


class Driver:
    def __init__(self, a):
        self.a = a
        self.out = Path(a.out).resolve()
        self.t0 = time.monotonic()
        self.budget = a.budget
        self.preset = getattr(a, "preset", "paper")
        self.kit = KIT
        self.outcomes = []
        self.missing = {}  # capability -> why the node lacks it (probe.py)
        self.found = []  # the probes' lines, for the summary
        self.died = None
        self.label = None
        self.env = None
        self.nvml = None  # gpu_state.Nvml once the GPU is found

    @property
    def done(self):
        return [(o.name, o.measured_s, o.estimate_s) for o in self.outcomes if o.result == "ok"]

    @property
    def failed(self):
        return [f"{o.name}: {o.why}" for o in self.outcomes if o.result == "FAILED"]

    @property
    def skipped(self):
        return [o.name for o in self.outcomes if o.result == "skipped"]

    def left(self):
        return self.budget - (time.monotonic() - self.t0)

    def say(self, msg):
        line = f"gpu-kit [{time.monotonic() - self.t0:5.0f} s]: {msg}"
        print(line, flush=True)
        if (self.out / "logs").is_dir():
            with open(self.out / "logs" / "progress.log", "a") as f:
                f.write(line + "\n")

    def rrv(self):
        return Path(os.environ.get("RRV_SCENES") or KIT / "scenes" / "rrv").resolve()

    def tokens(self):
        return {"FF_DIR": self.out / "ff", "RRV_SCENES": self.rrv(), "PRESET": self.preset,
                "RESULTS": self.out / "results" / (self.label or "unknown")}

    def records(self, experiment):
        return self.out / "results" / self.label / experiment / f"{self.preset}.jsonl"

    def read_records(self, experiment):
        """The records of one experiment made so far in this output folder (whole JSON lines only)."""
        f = self.records(experiment)
        out = []
        for line in (f.read_text(errors="replace").splitlines() if f.exists() else []):
            try:
                rec = json.loads(line)
            except ValueError:
                continue
            if isinstance(rec, dict):
                out.append(rec)
        return out

    def child_env(self, extra_dirs=(), first_dirs=()):
        """The node's environment, added to: on LD_LIBRARY_PATH the kit's lib/, then `first_dirs` (the kit's
        stand-ins for a library the node lacks), then the node's own folders (where its libcuda.so.1 may be), then
        `extra_dirs` (CUDA libraries found outside the loader's search)."""
        env = {k: v for k, v in os.environ.items() if not k.startswith("HPCGI_")}
        node = [d for d in os.environ.get("LD_LIBRARY_PATH", "").split(os.pathsep) if d]
        env["LD_LIBRARY_PATH"] = os.pathsep.join([str(KIT / "lib"), *first_dirs] + node +
                                                 [d for d in extra_dirs if d not in node])
        env["TMPDIR"] = str(self.out / "tmp")  # nothing is written outside the output folder
        env["PYTHONDONTWRITEBYTECODE"] = "1"
        env["RRV_SCENES"] = str(self.rrv())
        env.setdefault("OMP_PROC_BIND", "close")
        return env

    def plan(self):
        return plan.build(KIT, self.tokens(), probe.sanitizer_path(os.environ), self.preset, self.budget)

    # --- running ---
    def run_cmd(self, cmd, log):
        """(why it failed or None, its record or None)."""
        argv = [str(x) for x in cmd.argv]
        env = dict(self.env)
        if Path(argv[0]).name in ("poisson", "radiosity", "stream"):
            argv.append("--quiet")
            if cmd.json_out:
                argv.append("--json")
        if cmd.experiment:  # recorded: the case's id and its repeat, as slurm/run-case gives them
            rec = self.records(cmd.experiment)
            rec.parent.mkdir(parents=True, exist_ok=True)
            argv += ["--record", str(rec)]
            env.update(HPCGI_EXPERIMENT=cmd.experiment, HPCGI_PRESET=self.preset, HPCGI_CASE=cmd.case_id or "",
                       HPCGI_REPEAT=str(cmd.repeat), HPCGI_MACHINE_ID=os.environ.get("HPCGI_MACHINE_ID", ""),
                       HPCGI_MACHINE=self.label)
        limit = max(1.0, self.left() - RESERVE_S)
        before = self.gpu_sample() if cmd.experiment else None
        t = time.monotonic()
        with open(log, "a") as f:
            f.write("$ " + " ".join(argv) + "\n")
            f.flush()
            try:
                p = run_group(argv, env, limit, KIT)
            except subprocess.TimeoutExpired:
                return f"ran past what was left of the budget ({limit:.0f} s): stopped", None
            except OSError as e:
                return f"cannot run {argv[0]}: {e}", None
            f.write(p.stdout)
        if cmd.experiment:
            self.write_state(cmd, before, self.gpu_sample(), time.monotonic() - t, p.returncode)
        last = (p.stdout.strip().splitlines() or [""])[-1][:300]
        if p.returncode < 0:
            return f"killed by {signal_name(-p.returncode)}: {last}", None
        lines = [l for l in p.stdout.splitlines() if l.startswith("{")]
        rec = None
        if lines and cmd.json_out:
            try:
                rec = json.loads(lines[-1])
            except ValueError:
                return f"printed a garbled record: {lines[-1][:120]!r}", None
        if p.returncode != 0:
            return f"exit {p.returncode}: {last}", rec
        if cmd.text_check and cmd.text_check(p.stdout):
            return cmd.text_check(p.stdout), rec
        if cmd.check:
            return ("printed no record", None) if rec is None else (cmd.check(rec), rec)
        return None, rec

    def gpu_sample(self):
        try:
            return self.nvml.sample() if self.nvml else None
        except (OSError, ValueError) as e:  # NVML gone mid-run: said in the state line, never fatal
            return {"error": f"{type(e).__name__}: {e}"}

    def write_state(self, cmd, before, after, wall_s, status):
        """One line of the experiment's state file for a recorded run, as slurm/run-case writes them (case, repeat,
        utc, wall_s, exit_status, disturbed, reason), with the GPU's state before and after it and the node's load."""
        bad, why = gpu_state.disturbed(before, after)
        line = {"case": cmd.case_id, "repeat": cmd.repeat, "utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
                "wall_s": round(wall_s, 6), "exit_status": status, "disturbed": bad, "reason": why, "block": "gpu-kit",
                "load_after": round(os.getloadavg()[0], 2), "gpu_before": before, "gpu_after": after}
        if self.nvml is None:
            line["gpu_state"] = gpu_state.Nvml.why or "not sampled"
        state = self.records(cmd.experiment).with_suffix(".state.jsonl")
        with open(state, "a") as f:
            f.write(json.dumps(line, sort_keys=True) + "\n")

    def note(self, step, result, measured_s=None, why=""):
        self.outcomes.append(Outcome(step.name, step.group, step.estimate_s, result, measured_s, why))
        tail = f"({measured_s:.1f} s, estimated {step.estimate_s} s)" if measured_s is not None else ""
        self.say(f"{'ok' if result == 'ok' else result.upper()} {step.name} {tail}{': ' + why if why else ''}")

    def skip_reason(self, step):
        lacks = [self.missing[n] for n in sorted(step.needs) if n in self.missing]
        if lacks:
            return "the node lacks it: " + "; ".join(lacks)
        need = step.estimate_s * self.pace()
        if self.left() - RESERVE_S < need:
            return f"{self.left() - RESERVE_S:.0f} s left, it needs about {need:.0f} s"
        if step.optional and time.monotonic() - self.t0 + need > (1 - SLACK) * self.budget - RESERVE_S:
            return f"optional, and it would end past {1 - SLACK:.0%} of the budget at the measured pace"
        return None

    def run_step(self, step):
        why = self.skip_reason(step)
        if why:
            self.note(step, "skipped", why=why)
            return False
        product = plan.option(step.commands[0].argv, "-o") if step.group == "formfactors" else None
        if product and Path(product).is_file():  # a second run into the same folder: the solves check its header
            self.note(step, "ok", 0.0, f"{Path(product).name} already made")
            return True
        commands = step.prepare(self) if step.prepare else step.commands
        t = time.monotonic()
        log = self.out / "logs" / f"{step.group}.log"
        bad, recs = [], []
        for cmd in commands:
            why, rec = self.run_cmd(cmd, log)
            recs.append(rec)
            if why:
                bad.append(f"{' '.join(Path(str(x)).name for x in cmd.argv[:8])}: {why}")
        if not bad and step.check:
            why = step.check(recs)
            if why:
                bad.append(why)
        if bad:
            self.note(step, "FAILED", time.monotonic() - t, "; ".join(bad) + f" (see logs/{log.name})")
            return False
        self.note(step, "ok", time.monotonic() - t)
        return True

    def pace(self):
        """Measured seconds per estimated second of the steps run so far (1 until 10 estimated seconds ran),
        at least 0.5."""
        ran = [o for o in self.outcomes if o.result in ("ok", "FAILED") and o.measured_s and o.estimate_s]
        est = sum(o.estimate_s for o in ran)
        return 1.0 if est < 10 else max(0.5, sum(o.measured_s for o in ran) / est)

    def defer_late(self, queue, deferred):
        """When the steps still to run would end past the budget at the measured pace, the last ones are set aside,
        by name, until the rest fit; they run after all, in order, if time is left at the end."""
        late = []
        while len(queue) > 1 and (time.monotonic() - self.t0 + self.pace() * sum(s.estimate_s for s in queue)
                                  > self.budget - RESERVE_S):
            late.append(queue.pop())
        if late:
            self.say(f"running late (pace {self.pace():.2f} of the estimates): deferring the last {len(late)} steps "
                     f"to the end: " + "; ".join(s.name for s in reversed(late)))
            deferred[:0] = reversed(late)

    def run_all(self, steps):
        queue = [s for s in steps if not s.optional]
        optional = [s for s in steps if s.optional]
        deferred = []
        while queue:
            self.run_step(queue.pop(0))
            self.defer_late(queue, deferred)
        for s in deferred:
            if self.skip_reason(s) and not any(n in self.missing for n in s.needs):
                self.note(s, "skipped", why=f"deferred (running late at {self.pace():.2f} times the estimates), "
                                            f"and no time was left: {self.skip_reason(s)}")
            else:
                self.run_step(s)
        for s in optional:
            self.run_step(s)


def main(argv=None):
    ap = argparse.ArgumentParser(prog="gpu-kit/run", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dry-run", action="store_true", help="print the plan (steps, estimated seconds) and exit")
    ap.add_argument("--json", action="store_true", help="with --dry-run: the plan as JSON")
    ap.add_argument("--out", default="gpu-kit-out", help="output folder (default ./gpu-kit-out)")
    ap.add_argument("--budget", type=float, default=None,
                    help=f"seconds for the whole run (default BUDGET_S or {BUDGET_S})")
    ap.add_argument("--preset", choices=PRESETS, default="paper",
                    help="the case lists: paper (the report's sizes, default) or ci (tiny: a smoke run in seconds)")
    a = ap.parse_args(argv)
    if a.budget is None:
        try:
            a.budget = float(os.environ.get("BUDGET_S", str(BUDGET_S)))
        except ValueError:
            print(f"gpu-kit/run: BUDGET_S={os.environ['BUDGET_S']!r} is no number of seconds", file=sys.stderr)
            return EXIT_USAGE
    if not a.budget * (1 - SLACK) > RESERVE_S or a.budget != a.budget or a.budget == float("inf"):
        print(f"gpu-kit/run: the budget must be a finite number of seconds above {RESERVE_S / (1 - SLACK):g}, got "
              f"{a.budget:g}", file=sys.stderr)
        return EXIT_USAGE
    if not (KIT / "cases" / a.preset).is_dir():
        print(f"gpu-kit/run: this kit carries no case lists of preset {a.preset} ({KIT / 'cases'})", file=sys.stderr)
        return EXIT_USAGE
    d = Driver(a)
    # The node's id (common/machine_label.py) is kept in the output folder, as everything the kit writes: the same
    # --out gives the same label again; the programs' records carry it (HPCGI_MACHINE_ID in their environment).
    if a.dry_run and not os.environ.get("HPCGI_MACHINE_ID"):
        os.environ["HPCGI_MACHINE_ID"] = "0" * 12  # a dry run writes nothing, not even the node's id
    if not os.environ.get("HPCGI_MACHINE_ID") and not os.environ.get("HPCGI_STATE_DIR"):
        os.environ["HPCGI_STATE_DIR"] = str(d.out / "state")
    try:
        os.environ["HPCGI_MACHINE_ID"] = machine_label.machine_id()
        d.label = machine_label.describe()["label"]
    except ValueError as e:
        print(f"gpu-kit/run: {e}", file=sys.stderr)
        return EXIT_USAGE
    steps = d.plan()
    if a.dry_run:
        if a.json:
            fit = plan.fitting(steps, a.budget)
            gpu = [{"experiment": c.experiment, "index": c.index, "line": c.line}
                   for c in cases.gpu_cases(KIT / "cases" / a.preset, a.preset)]
            print(json.dumps({"budget_s": a.budget, "reserve_s": RESERVE_S, "slack": SLACK, "preset": a.preset,
                              "phases": list(plan.PHASES), "gpu_cases": gpu,
                              "steps": [{"name": s.name, "group": s.group, "phase": s.phase,
                                         "estimate_s": s.estimate_s, "optional": s.optional, "fit": fit[s.name],
                                         "needs": sorted(s.needs)} for s in steps]}))
        else:
            plan.print_plan(steps, a.budget)
        return EXIT_OK
    return run(d, steps)


def run(d, steps):
    """Probes the node, runs the plan, and always writes the summary and the archive. Returns the exit status."""
    for sub in ("logs", "tmp", "ff", "results/" + d.label):
        (d.out / sub).mkdir(parents=True, exist_ok=True)

    def stop(signum, _frame):
        raise Stopped(f"told to stop by {signal_name(signum)}")

    # a signal ignored at the start (nohup's SIGHUP) stays ignored
    old = {s: signal.signal(s, stop) for s in (signal.SIGTERM, signal.SIGHUP) if signal.getsignal(s) != signal.SIG_IGN}
    status = None
    try:
        status = node.go(d, steps, KIT)
    except BaseException as e:  # the driver's own death: said, and the summary and the archive still written
        d.died = f"{type(e).__name__}: {e}".rstrip(": ")
        (d.out / "logs" / "driver-traceback.txt").write_text(traceback.format_exc())
        d.say(f"THE DRIVER STOPPED: {d.died} (logs/driver-traceback.txt); writing the summary and the archive")
    finally:
        for s, h in old.items():
            signal.signal(s, h)
    text = write_summary(d)
    try:
        archive = pack_archive(d.out, d.label)
        d.say(f"archive {archive} ({archive.stat().st_size / 2**20:.2f} MiB): bring it home, then "
              f"make gpu-import ARCHIVE={archive.name}")
    except Exception as e:
        print(f"gpu-kit: the archive could not be made: {type(e).__name__}: {e}", file=sys.stderr)
        return EXIT_FAILED
    print(text)
    if status == EXIT_NO_GPU:
        return status
    return EXIT_FAILED if d.died or d.failed else EXIT_SKIPPED if d.skipped else EXIT_OK


def write_summary(d):
    try:
        text = summary.write(d.out / "results" / d.label, KIT / "paper", d)
    except Exception:  # the archive must still be made: the records are what counts
        d.outcomes.append(Outcome("summary", "driver", 0, "FAILED", why=traceback.format_exc().splitlines()[-1]))
        text = "# GPU kit summary\n\nThe summary failed:\n\n```\n" + traceback.format_exc() + "```\n"
    (d.out / "summary.md").write_text(text)
    return text


if __name__ == "__main__":
    sys.exit(main())
