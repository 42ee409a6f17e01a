#!/usr/bin/env python3
"""gpu-kit/device-run: the kit on a lent GPU machine whose output folder comes back with few, small files.

    gpu-kit/device-run [--limit S] [--out DIR] [--work DIR] [--preset paper|ci]
                       (env: OUT, the folder that comes back; DEVICE_LIMIT_S; RRV_SCENES, MACHINE as for gpu-kit/run)

A lent machine gives a command a time limit (the call's timeout_s, at most 600 s) and brings back from $OUT at most
8 files of at most 16 MiB each, 2 folders deep. So this runs gpu-kit/run with its work files (form factors of 1.6
GB, records, logs) in a work folder outside $OUT (default $TMPDIR/gpu-kit-work; kept, so that a second call on the
same warm machine reuses the form factors), and stops it well inside the limit:
  - the kit's budget is the limit less MARGIN_S (60 s): the kit plans for it and stops its own steps there;
  - should the kit still run MARGIN_S - 45 s later, it is sent SIGTERM (which it turns into its summary and archive),
    and 20 s after that it and every process under it are killed (this script is their subreaper, so a process
    that left its parent's session is still found, by pid);
  - SIGTERM, SIGINT or SIGHUP to this script is passed on to the kit the same way (one ignored at the start stays
    ignored).
Into $OUT, at its top, it writes only: nvidia-smi-before.txt and nvidia-smi-after.txt (`nvidia-smi -q`, or why
not), progress.log (the kit's progress, copied every 10 s while it runs, so that it comes back even from a hard
kill, with this script's own lines), summary.md and gpu-kit-<label>.tar.gz, each checked to be under 16 MiB.
Bring the archive home and `make gpu-import ARCHIVE=...`.

Exit status: the kit's (0 every step ran and passed, 1 a step failed, 3 no GPU, 6 some skipped); 1 when the kit
had to be stopped by a signal or its archive did not come; 2 bad arguments (one line, nothing written)."""
import argparse
import ctypes
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

KIT = Path(__file__).resolve().parent.parent
MARGIN_S = 60  # the limit less the kit's budget: its stop, the summary, the archive, nvidia-smi and the copies
TERM_AFTER_S = 15  # after the budget: SIGTERM to the kit
KILL_AFTER_S = 35  # after the budget: SIGKILL to the kit and everything under it
COPY_EVERY_S = 10
FILE_LIMIT = 16 << 20  # what comes back from $OUT: each file under this
DEFAULT_LIMIT_S = 420
KIT_MIN_BUDGET_S = 13  # gpu-kit/run's least budget: its reserve over (1 - slack)


def say(out, msg):
    line = f"device-run [{time.strftime('%H:%M:%S', time.gmtime())} UTC]: {msg}"
    print(line, flush=True)
    try:
        with open(out / "progress.log", "a") as f:
            f.write(line + "\n")
    except OSError:
        pass


def nvidia_smi(path):
    """`nvidia-smi -q` into path, or one line saying why not (never more than 20 s)."""
    smi = shutil.which("nvidia-smi")
    try:
        if smi is None:
            text = "nvidia-smi: not found on PATH\n"
        else:
            p = subprocess.run([smi, "-q"], capture_output=True, text=True, errors="replace", timeout=20)
            text = p.stdout + p.stderr + ("" if p.returncode == 0 else f"nvidia-smi -q: exit {p.returncode}\n")
    except (OSError, subprocess.TimeoutExpired) as e:
        text = f"nvidia-smi -q: {type(e).__name__}: {e}\n"
    path.write_text(text[-(FILE_LIMIT // 2):])


def copy_small(src, dst, out):
    """src to dst (written beside, then renamed), if under FILE_LIMIT; a text log over it keeps its end."""
    if not src.is_file():
        return False
    size = src.stat().st_size
    tmp = dst.with_name("." + dst.name + ".part")
    if size >= FILE_LIMIT:
        if dst.suffix != ".log":
            say(out, f"{src.name} is {size / 2**20:.1f} MiB, over what comes back: not copied")
            return False
        with open(src, "rb") as f:
            f.seek(size - FILE_LIMIT // 2)
            tmp.write_bytes(f.read())
    else:
        shutil.copyfile(src, tmp)
    os.replace(tmp, dst)
    return True


def children():
    """The pids whose parent is this process (as subreaper, the orphans under it too)."""
    me, out = os.getpid(), []
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                stat = Path(f"/proc/{d}/stat").read_text()
            except OSError:
                continue
            fields = stat[stat.rindex(")") + 2:].split()
            if int(fields[1]) == me:
                out.append(int(d))
    return out


def end_all(kit_pid):
    """Kills the kit (by its pid) and every process left under this one, and reaps them; returns how many."""
    killed = 0
    for _ in range(50):
        pids = children()
        if not pids:
            return killed
        for pid in pids:
            try:
                os.kill(pid, signal.SIGKILL)
                killed += pid != kit_pid
            except ProcessLookupError:
                pass
        for pid in pids:
            try:
                os.waitpid(pid, 0)
            except ChildProcessError:
                pass
        time.sleep(0.05)
    return killed


def main(argv=None):
    ap = argparse.ArgumentParser(prog="gpu-kit/device-run", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--limit", type=float, default=None,
                    help=f"seconds the lent machine gives the command (its timeout_s; default DEVICE_LIMIT_S or "
                         f"{DEFAULT_LIMIT_S})")
    ap.add_argument("--out", default=os.environ.get("OUT"), help="the folder that comes back (default $OUT)")
    ap.add_argument("--work", default=None, help="the kit's work folder, outside --out (default $TMPDIR/gpu-kit-work)")
    ap.add_argument("--preset", choices=("paper", "ci"), default="paper", help="gpu-kit/run's --preset")
    a = ap.parse_args(argv)
    try:
        limit = a.limit if a.limit is not None else float(os.environ.get("DEVICE_LIMIT_S", DEFAULT_LIMIT_S))
    except ValueError:
        ap.exit(2, f"gpu-kit/device-run: DEVICE_LIMIT_S={os.environ['DEVICE_LIMIT_S']!r} is no number of seconds\n")
    budget = limit - MARGIN_S
    if not budget >= KIT_MIN_BUDGET_S or limit == float("inf"):
        ap.exit(2, f"gpu-kit/device-run: --limit must be at least {MARGIN_S + KIT_MIN_BUDGET_S} s (the kit's budget is "
                   f"the limit less {MARGIN_S} s), got {limit:g}\n")
    if not a.out:
        ap.exit(2, "gpu-kit/device-run: say where the files that come back go: $OUT or --out DIR\n")
    out = Path(a.out).resolve()
    work = Path(a.work or os.path.join(os.environ.get("TMPDIR") or "/tmp", "gpu-kit-work")).resolve()
    if work == out or out in work.parents:
        ap.exit(2, f"gpu-kit/device-run: the work folder {work} is inside the output folder {out}: its gigabytes would "
                   f"not come back; give --work elsewhere\n")
    if not out.is_dir():
        ap.exit(2, f"gpu-kit/device-run: the output folder {out} is no folder\n")
    work.mkdir(parents=True, exist_ok=True)
    return run(out, work, limit, budget, a.preset)


def run(out, work, limit, budget, preset):
    t0 = time.monotonic()
    stop = {"signal": None}

    def on_signal(signum, _frame):
        stop["signal"] = signum

    for s in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP):
        if signal.getsignal(s) != signal.SIG_IGN:
            signal.signal(s, on_signal)
    try:
        ctypes.CDLL(None, use_errno=True).prctl(36, 1)  # PR_SET_CHILD_SUBREAPER: orphans under the kit come here
    except (OSError, AttributeError):
        pass
    say(out, f"limit {limit:.0f} s: the kit's budget {budget:.0f} s, SIGTERM at {budget + TERM_AFTER_S:.0f} s, kill at "
             f"{budget + KILL_AFTER_S:.0f} s; work folder {work}; output {out}")
    nvidia_smi(out / "nvidia-smi-before.txt")
    env = dict(os.environ)
    env.pop("OUT", None)  # the kit's output is the work folder, never $OUT
    kit = subprocess.Popen([sys.executable, "-B", str(KIT / "gpukit" / "driver.py"), "--out", str(work),
                            "--budget", f"{budget:g}", "--preset", preset], cwd=str(work), env=env)
    progress, last_copy, termed, killed = work / "logs" / "progress.log", 0.0, None, 0
    while kit.poll() is None:
        time.sleep(0.5)
        now = time.monotonic() - t0
        if now - last_copy >= COPY_EVERY_S:
            copy_progress(progress, out)
            last_copy = now
        if termed is None and (stop["signal"] or now >= budget + TERM_AFTER_S):
            why = f"told to stop by {signal.Signals(stop['signal']).name}" if stop["signal"] else "past its budget"
            say(out, f"the kit is {why}: SIGTERM to it (its summary and archive are written on it)")
            kit.send_signal(signal.SIGTERM)
            termed = now
        if termed is not None and now >= min(budget + KILL_AFTER_S, termed + KILL_AFTER_S - TERM_AFTER_S):
            say(out, "the kit did not end after SIGTERM: killing it and every process under it")
            killed = end_all(kit.pid) or 1
            break
    status = -signal.SIGKILL if killed else kit.wait()
    left = end_all(kit.pid)
    if left:
        say(out, f"{left} processes were left under the kit after it ended: killed")
    copy_progress(progress, out)
    nvidia_smi(out / "nvidia-smi-after.txt")
    copied = [copy_small(work / "summary.md", out / "summary.md", out)]
    archives = sorted(work.glob("gpu-kit-*.tar.gz"), key=lambda p: p.stat().st_mtime)
    copied.append(bool(archives) and copy_small(archives[-1], out / archives[-1].name, out))
    copy_progress(progress, out)
    files = sorted(p.name for p in out.iterdir() if p.is_file())
    say(out, f"the kit exited {status} after {time.monotonic() - t0:.0f} s; in {out}: {', '.join(files)}")
    if not copied[1]:
        say(out, "NO ARCHIVE came back: the records of this run are only in " + str(work))
    if killed or termed is not None or not copied[1]:
        return 1 if status in (0, 6) or status < 0 else status
    return status


def copy_progress(progress, out):
    """The kit's progress log into $OUT, this script's own lines after it."""
    mine = [l for l in ((out / "progress.log").read_text(errors="replace").splitlines(keepends=True)
                        if (out / "progress.log").is_file() else []) if l.startswith("device-run [")]
    tmp = out / ".progress.log.part"
    data = (progress.read_bytes()[-(FILE_LIMIT // 2):] if progress.is_file() else b"") + "".join(mine).encode()
    tmp.write_bytes(data)
    os.replace(tmp, out / "progress.log")


if __name__ == "__main__":
    sys.exit(main())
