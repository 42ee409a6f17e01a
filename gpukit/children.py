"""The kit's children: each in a session of its own, killed with everything under it at its time limit, when the
driver is stopped, or when the driver dies. Standard library only (it runs on the GPU node)."""
import os
import signal
import subprocess


def signal_name(n):
    try:
        return signal.Signals(n).name
    except ValueError:
        return f"signal {n}"


def _die_with_parent():
    """In the child before exec: killed when the driver dies (SIGKILL at a device's time limit), since its own
    session puts it out of reach of a kill of the driver's process group."""
    try:
        import ctypes
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


def run_group(argv, env, limit, cwd):
    """subprocess.run in a process group of its own, the whole group killed at the time limit (compute-sanitizer
    runs the program as its child, which a plain timeout would leave running) or when the driver is stopped."""
    p = subprocess.Popen(argv, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                         errors="replace", start_new_session=True, preexec_fn=_die_with_parent)
    try:
        out, _ = p.communicate(timeout=limit)
    except BaseException:
        try:
            os.killpg(p.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        p.communicate()
        raise
    return subprocess.CompletedProcess(argv, p.returncode, out)
