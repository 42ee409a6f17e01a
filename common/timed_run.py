#!/usr/bin/env python3
"""Runs one timed run of a case and writes the machine's state beside its record (the timing protocol,
common/timing_protocol.py): slurm/run-case calls it for every repeat of a timed case.

    common/timed_run.py --state FILE --case CASE --repeat R [--probe "CMD"] [--block NAME] [--oversubscribed]
                        -- PROGRAM ARGS...

It runs PROGRAM with its arguments, its standard streams and its exit status passed through (a program killed by a
signal gives 128 + the signal, as a shell reports it), and appends one JSON line to FILE:
  {"case", "repeat", "utc", "wall_s", "load_before", "load_after", "others_cpu", "steal", "cpu_pressure",
   "runnable_before", "runnable_after", "oversubscribed", "probe_before_gbs", "probe_after_gbs", "disturbed",
   "reason", "block"}
- block: the block whose rounds the run was in (slurm/run-local runs the experiments a claim compares together, so
  that the runs of one round of one block are a claim's pairs: analysis/verdict.py);
- others_cpu: the share of the machine's CPU time used by anything but this run while it ran (/proc/stat's busy
  time less the run's own, from wait4), steal: the share stolen by the hypervisor;
- probe_*: a short memory-bandwidth probe (--probe, bin/stream's triad in GB/s) just before and just after;
- cpu_pressure: the share of the run's wall time in which some task waited for a CPU (/proc/pressure/cpu's
  "some" total, in microseconds: what the load average sees, without its minute of lag, and on a run of any
  length); runnable_before/after: the tasks runnable at that instant besides this one (/proc/loadavg);
- disturbed: others_cpu above 10% of the machine, steal above 5%, CPU pressure above 10% (not asked of a run that
  oversubscribes the cores itself: --oversubscribed), as many other runnable tasks as cores before or after it,
  or both probes below 80% of the baseline: the median of the last 20 probes in the state file (the bandwidth
  drifts with the VM's neighbours: a run is judged against the minutes around it), else the session's start
  ($HPCGI_PROBE_BASELINE_GBS, measured by slurm/run-local); a probe that is no plausible bandwidth (not finite, not
  above 0, above 100 TB/s) is no baseline. The 1-minute load average is written beside them but decides nothing:
  it lags by a minute and counts this study's own runs.
A disturbed run stays in the records; the tables leave it out of their medians and count it. The state line is
appended whole or not at all (common/harness_io.py): where it cannot be (a full disk, a state path that is no
regular file), the run's exit status becomes 1 with one line, since its record is there without its state.
Standard library only. A signal ignored at start stays ignored (the child inherits it)."""
import json
import math
import os
import re
import signal
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # the repository or the kit
from common import harness_io  # noqa: E402  (the one way to open a harness file)

OTHERS_MAX = 0.10
STEAL_MAX = 0.05
PRESSURE_MAX = 0.10
PROBE_MIN = 0.80
PROBE_MAX_GBS = 1e5  # no memory streams 100 TB/s: a probe above it (or not above 0) is no measurement
TICK = os.sysconf("SC_CLK_TCK")
CORES = os.sysconf("SC_NPROCESSORS_ONLN") or 1


def cpu_pressure_us():
    """/proc/pressure/cpu's "some" total: microseconds in which some task waited for a CPU; None without PSI."""
    try:
        with open("/proc/pressure/cpu") as f:
            for line in f:
                if line.startswith("some"):
                    return int(line.rsplit("total=", 1)[1])
    except (OSError, ValueError, IndexError):
        pass
    return None


def runnable_others():
    """Tasks runnable at this instant besides this one (/proc/loadavg's fourth field, "runnable/total")."""
    try:
        with open("/proc/loadavg") as f:
            return max(0, int(f.read().split()[3].split("/")[0]) - 1)
    except (OSError, ValueError, IndexError):
        return None


def plausible(gbs):
    return isinstance(gbs, (int, float)) and not isinstance(gbs, bool) and math.isfinite(gbs) and 0 < gbs < PROBE_MAX_GBS


def cpu_ticks():
    """(busy ticks of all CPUs but idle and iowait, steal ticks), from /proc/stat's first line."""
    try:
        with open("/proc/stat") as f:
            v = [int(x) for x in f.readline().split()[1:9]]
    except (OSError, ValueError):
        return None
    user, nice, system, _idle, _iowait, irq, softirq, steal = (v + [0] * 8)[:8]
    return user + nice + system + irq + softirq + steal, steal


def load1():
    try:
        with open("/proc/loadavg") as f:
            return float(f.read().split()[0])
    except (OSError, ValueError, IndexError):
        return None


def probe(cmd):
    """The probe's triad bandwidth in GB/s, or None where there is no probe or it said nothing readable."""
    if not cmd:
        return None
    try:
        out = subprocess.run(cmd, shell=False, capture_output=True, text=True, timeout=30).stdout
    except (OSError, subprocess.TimeoutExpired):
        return None
    m = re.search(r"triad\D*?([0-9.]+)\s*GB/s", out, re.I)
    return float(m.group(1)) if m else None


def judge(others, steal, pb, pa, baseline, pressure=None, runnable=(None, None)):
    reasons = []
    if others is not None and others > OTHERS_MAX:
        reasons.append(f"other processes used {100 * others:.0f}% of the CPUs")
    if steal is not None and steal > STEAL_MAX:
        reasons.append(f"the hypervisor stole {100 * steal:.0f}% of the CPU time")
    if pressure is not None and pressure > PRESSURE_MAX:
        reasons.append(f"tasks waited for a CPU {100 * pressure:.0f}% of the time (CPU pressure)")
    busy = [n for n in runnable if n is not None and n >= CORES]
    if busy:
        reasons.append(f"{max(busy)} other tasks were runnable on {CORES} cores")
    probes = [p for p in (pb, pa) if p is not None]
    if baseline and probes and all(p < PROBE_MIN * baseline for p in probes):  # before and after: not one dip
        reasons.append(f"memory bandwidth probes {', '.join(f'{p:.1f}' for p in probes)} GB/s < {PROBE_MIN:.0%} of "
                       f"{baseline:.1f} GB/s")
    return bool(reasons), "; ".join(reasons) or None


def recent_baseline(state, fallback, keep=20):
    """The median of the last `keep` probes in the state file (the machine's bandwidth drifts with its neighbours:
    a run is judged against the minutes around it), or `fallback` (the session's start) with fewer than 5."""
    vals = []
    good, _ = harness_io.read_objects(state)  # a line that is no JSON object is no probe
    for _, d in good:
        vals += [d[k] for k in ("probe_before_gbs", "probe_after_gbs") if plausible(d.get(k))]
    vals = sorted(vals[-keep:])
    return vals[len(vals) // 2] if len(vals) >= 5 else fallback if plausible(fallback) else None


def ignored_at_start():
    """The signals among SIGPIPE and SIGXFSZ that this process was started with ignored. Python ignores both itself
    before any of our code runs, so they are read from the parent that started us (a shell's ignored signals are
    the ones its children inherit); empty where that cannot be read."""
    try:
        with open(f"/proc/{os.getppid()}/status") as f:
            mask = int(next(l for l in f if l.startswith("SigIgn:")).split()[1], 16)
    except (OSError, StopIteration, ValueError):
        return set()
    return {s for s in (signal.SIGPIPE, signal.SIGXFSZ) if mask >> (s - 1) & 1}


def _child_signals(keep):
    """In the child before exec: SIGPIPE and SIGXFSZ back to their default, except those ignored at our start
    (a full disk or a file-size limit is then an error the program reports, as its caller asked)."""
    for s in (signal.SIGPIPE, signal.SIGXFSZ):
        if s not in keep:
            signal.signal(s, signal.SIG_DFL)


def run(cmd):
    """Runs cmd; (exit status as a shell reports it, wall seconds, the child's CPU seconds)."""
    t0 = time.monotonic()
    keep = ignored_at_start()
    try:
        child = subprocess.Popen(cmd, restore_signals=False, preexec_fn=lambda: _child_signals(keep))
    except OSError as e:
        print(f"timed_run: cannot run {cmd[0]}: {e.strerror}", file=sys.stderr)
        return 127, 0.0, 0.0
    while True:
        try:
            _, status, usage = os.wait4(child.pid, 0)
            break
        except KeyboardInterrupt:  # SIGINT reached us too (it was not ignored): the child decides what it does
            continue
    wall = time.monotonic() - t0
    code = 128 + os.WTERMSIG(status) if os.WIFSIGNALED(status) else os.WEXITSTATUS(status)
    return code, wall, usage.ru_utime + usage.ru_stime


def parse(argv):
    if "--" not in argv:
        raise ValueError("usage: common/timed_run.py --state FILE --case CASE --repeat R [--probe CMD] -- PROGRAM ARGS...")
    k = argv.index("--")
    opts, cmd = argv[:k], argv[k + 1:]
    over = "--oversubscribed" in opts
    opts = [o for o in opts if o != "--oversubscribed"]
    d = dict(zip(opts[::2], opts[1::2]))
    if not set(d) <= {"--state", "--case", "--repeat", "--probe", "--block"}:
        raise ValueError(f"unknown option {sorted(set(d) - {'--state', '--case', '--repeat', '--probe', '--block'})[0]}")
    if len(opts) % 2 or not cmd or not {"--state", "--case", "--repeat"} <= d.keys() or not d["--repeat"].isdigit():
        raise ValueError("usage: common/timed_run.py --state FILE --case CASE --repeat R [--probe CMD] [--block NAME] "
                         "[--oversubscribed] -- PROGRAM ARGS...")
    d["--oversubscribed"] = over
    return d, cmd


def main(argv):
    if argv[:1] in (["-h"], ["--help"]):
        print(__doc__)
        return 0
    try:
        d, cmd = parse(argv)
    except ValueError as e:
        print(f"timed_run: {e}", file=sys.stderr)
        return 2
    probe_cmd = d.get("--probe", "").split()
    try:
        baseline = float(os.environ.get("HPCGI_PROBE_BASELINE_GBS") or 0) or None
    except ValueError:
        baseline = None
    try:
        baseline = recent_baseline(d["--state"], baseline)
    except harness_io.HarnessFileError as e:
        print(f"timed_run: {e}", file=sys.stderr)
        return 2
    la, pb = load1(), probe(probe_cmd)
    rb = runnable_others()
    t0, p0 = cpu_ticks(), cpu_pressure_us()
    code, wall, own_cpu = run(cmd)
    t1, p1 = cpu_ticks(), cpu_pressure_us()
    ra = runnable_others()
    pa, lb = probe(probe_cmd), load1()
    others = steal = pressure = None
    if t0 and t1 and wall > 0:
        capacity = wall * CORES
        # /proc/stat counts in ticks: one tick of slack either way, so that a short run is not flagged by rounding
        others = max(0.0, ((t1[0] - t0[0] - 2) / TICK - own_cpu) / capacity)
        steal = max(0.0, (t1[1] - t0[1] - 1) / TICK / capacity)
    if p0 is not None and p1 is not None and wall > 0 and not d["--oversubscribed"]:
        pressure = max(0.0, (p1 - p0) / 1e6 / wall)
    disturbed, reason = judge(others, steal, pb, pa, baseline, pressure,
                              (None, None) if d["--oversubscribed"] else (rb, ra))
    line = {"case": d["--case"], "repeat": int(d["--repeat"]), "utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
            "wall_s": round(wall, 6), "exit_status": code, "load_before": la, "load_after": lb,
            "others_cpu": None if others is None else round(others, 4),
            "steal": None if steal is None else round(steal, 4),
            "cpu_pressure": None if pressure is None else round(pressure, 4), "runnable_before": rb,
            "runnable_after": ra, "oversubscribed": d["--oversubscribed"], "probe_before_gbs": pb,
            "probe_after_gbs": pa, "probe_baseline_gbs": baseline, "disturbed": disturbed, "reason": reason,
            "block": d.get("--block") or None}
    try:
        harness_io.append_line(d["--state"], json.dumps(line, sort_keys=True))
    except harness_io.HarnessFileError as e:
        print(f"timed_run: the run's state was not kept: {e}", file=sys.stderr)
        return 1 if code == 0 else code
    return code


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
