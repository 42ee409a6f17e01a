"""Run records written from Python (the peers of `make bench`), in the schema of common/record.hpp: one JSON object
per line with schema, app, params, result, times_s, perf, backend_info and provenance, appended by one write()
under an exclusive flock and cut back if the write fails, so a reader never sees half a line."""
import fcntl
import json
import math
import os
import platform
import socket
import subprocess
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
# The record's one definition (JSON Schema), which common/record.cpp builds in: its version and the environment keys
# a record keeps (what decides threads and placement, and the harness's case identifiers).
SCHEMA_FILE = ROOT / "common" / "record.schema.json"
DEFINITION = json.loads(SCHEMA_FILE.read_text())
SCHEMA = DEFINITION["$id"]
ENV_KEYS = tuple(DEFINITION["properties"]["provenance"]["properties"]["env"]["propertyNames"]["enum"])

_validator = []


def _refuse_constant(token):
    raise ValueError(f"{token} is no JSON number (a record's numbers are finite)")


def _finite_float(text):
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"{text[:40]} is beyond a double (a record's numbers are finite)")
    return value


def loads(line):
    """One record line as JSON, refusing what Python's json would take into medians: the tokens NaN, Infinity and
    -Infinity, which are no JSON, and numbers beyond a double (1e999), which it reads as infinite. ValueError for
    those as for any text that is no JSON."""
    try:
        return json.loads(line, parse_constant=_refuse_constant, parse_float=_finite_float)
    except RecursionError:
        raise ValueError("nested too deeply") from None


def _nonfinite(value, where=""):
    """The path of the first NaN or infinite number in a decoded record, or None."""
    if isinstance(value, float) and not math.isfinite(value):
        return where or "the record"
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else ()
    for k, v in items:
        found = _nonfinite(v, f"{where}/{k}" if where else str(k))
        if found:
            return found
    return None


def _finite(value):
    """value with every NaN and infinite float replaced by None, as common/record.cpp (nlohmann::json) writes them."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_finite(v) for v in value]
    return value


def dumps(rec):
    """A record as one line of JSON, non-finite numbers written as null (never the NaN token no reader takes)."""
    return json.dumps(_finite(rec), separators=(",", ":"), allow_nan=False)


def validate(rec):
    """What is wrong with a record against common/record.schema.json (its first error, with where), or None. A NaN
    or infinite number anywhere is wrong too (the schema's bounds refuse infinities only where it names a number).
    Needs the package jsonschema (requirements.txt)."""
    try:
        bad = _nonfinite(rec)
    except RecursionError:
        return "the record: nested too deeply"
    if bad:
        return f"{bad}: a non-finite number (NaN or Infinity)"
    if not _validator:
        import jsonschema
        _validator.append(jsonschema.Draft202012Validator(DEFINITION))
    import jsonschema.exceptions
    err = jsonschema.exceptions.best_match(_validator[0].iter_errors(rec))
    if err is None:
        return None
    where = "/".join(str(p) for p in err.absolute_path) or "the record"
    return f"{where}: {err.message}"


def _git(*args):
    try:
        return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None


def _cpu_model():
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def provenance(libraries=None):
    """What ran and where: git commit and dirty flag, Python and library versions (`libraries`: name -> version
    text, e.g. numpy's and its BLAS), host, CPU, threads, the environment of ENV_KEYS, UTC time."""
    head = _git("rev-parse", "HEAD")
    # dirty as the Makefile's GIT_CHANGES has it for the C++ programs: a tracked file that differs from HEAD or an
    # untracked one not ignored, the study's outputs (results/, report/) left out, since the runs write them
    changes = _git("status", "--porcelain", "--", ".", ":(exclude)results", ":(exclude)report")
    p = {
        "git_commit": head.stdout.strip() if head and head.returncode == 0 else "unknown",
        "git_dirty": bool(head is None or head.returncode != 0 or changes is None or changes.returncode != 0
                          or changes.stdout.strip()),
        "compiler": f"Python {platform.python_version()} ({platform.python_implementation()})",
        "libraries": dict(libraries or {}),
        "host": socket.gethostname(),
        "os": f"{platform.system()} {platform.release()} {platform.machine()}",
        "cpu_model": _cpu_model(),
        "cpus_online": os.cpu_count(),
        "utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }
    env = {k: os.environ[k] for k in ENV_KEYS if os.environ.get(k)}
    if env:
        p["env"] = env
    return p


# The exit statuses of common/errors.hpp that end a run with its record (result.exit_status): 0 an answer, 3 a
# numerical failure, 4 not converged within --max-iter, 5 disagreed with its float64 check.
EXIT_OK, EXIT_NUMERICAL, EXIT_NOT_CONVERGED, EXIT_DISAGREED = 0, 3, 4, 5


def set_outcome(rec, status, reason=None):
    """result.exit_status and result.exit_reason (None for 0, else the one line on stderr), as common/record.cpp's
    set_outcome; returns the status, the run's exit status."""
    rec["result"]["exit_status"] = status
    rec["result"]["exit_reason"] = None if status == EXIT_OK else reason
    return status


def make(app, libraries=None):
    """A new record with schema, app and provenance filled in."""
    return {"schema": SCHEMA, "app": app, "provenance": provenance(libraries)}


def append(path, rec):
    """Appends rec as one line to path (parent folders are created), atomically as common/record.cpp does."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    line = (dumps(rec) + "\n").encode()
    fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_CLOEXEC, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        old = os.fstat(fd).st_size
        try:
            if os.write(fd, line) != len(line):
                raise OSError(f"short write to {path} (disk full?)")
            os.fsync(fd)
        except OSError:
            os.ftruncate(fd, old)
            raise
    finally:
        os.close(fd)  # releases the lock


def add_options(parser):
    """--record FILE, --json and --quiet, as every program of the project takes them (common/cli.hpp)."""
    parser.add_argument("--record", help="append one JSON record of this run to FILE (JSON Lines)")
    parser.add_argument("--json", action="store_true", help="print the record on stdout")
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors (and the record with --json)")


def process_seconds():
    """Seconds since this process began (its start time in /proc/self/stat, in clock ticks, against CLOCK_BOOTTIME),
    the interpreter's start and imports included, as common/record.hpp's process_seconds; None where the system does
    not say."""
    try:
        with open("/proc/self/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()  # the command name, in parentheses, may hold spaces
        up = time.clock_gettime(time.CLOCK_BOOTTIME) - int(fields[19]) / os.sysconf("SC_CLK_TCK")  # field 22
    except (OSError, IndexError, ValueError, AttributeError):
        return None
    return up if 0 <= up < 1e7 else None


def emit(rec, args):
    """The end of every run that makes a record: printed with --json, appended to --record's file, with
    times_s.process (process_seconds) at that moment."""
    up = process_seconds()
    if up is not None:
        rec.setdefault("times_s", {})["process"] = up
    if args.json:
        print(dumps(rec), flush=True)
    if args.record:
        append(args.record, rec)
