"""Shared helpers of the integration tests: run the real binaries from bin/ as a user would."""
import json
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
BIN = ROOT / "bin"

# The tests' machine: an id of its own for the whole session (common/machine_label.py keeps a machine's id in
# HPCGI_STATE_DIR), so that no test reads or makes the id of the machine it runs on.
os.environ.setdefault("HPCGI_STATE_DIR", tempfile.mkdtemp(prefix="hpcgi-test-machine-"))

# OpenMPI refuses to run as root unless told; CI runs as root.
MPI_ENV = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1", "OMPI_MCA_rmaps_base_oversubscribe": "1"}


def run(args, env=None, timeout=300, **kw):
    """Runs a command, returns the CompletedProcess (text output)."""
    full_env = dict(os.environ, **(env or {}))
    return subprocess.run([str(a) for a in args], capture_output=True, text=True, timeout=timeout, env=full_env, **kw)


def _rrv_scenes():
    """The folder RRV's scenes are read from, as the programs' callers find it (radiosity/scenes/rrv/dir: RRV_SCENES,
    make scenes' cache, ../shared/scenes/rrv), and whether it holds room2.xml, room3.xml and teapot.obj."""
    p = run([ROOT / "radiosity" / "scenes" / "rrv" / "dir"])
    return Path(p.stdout.strip()), p.returncode == 0


RRV, HAVE_RRV = _rrv_scenes()
RRV_ABSENT = f"RRV's scenes not found in {RRV}: run 'make scenes' or set RRV_SCENES"


def poisson(*args, np=None, timeout=300):
    """Runs bin/poisson --json --quiet with args (under mpirun -np NP if np) and returns (process, record or None)."""
    cmd = [BIN / "poisson", "--json", "--quiet", *args]
    env = None
    if np is not None:
        cmd = ["mpirun", "-np", str(np), *cmd]
        env = MPI_ENV
    p = run(cmd, env=env, timeout=timeout)
    rec = None
    if p.returncode == 0:
        lines = [l for l in p.stdout.splitlines() if l.startswith("{")]
        assert len(lines) == 1, f"expected one record on stdout, got: {p.stdout!r}"
        rec = json.loads(lines[0])
    return p, rec


def have_mpi():
    return shutil.which("mpirun") is not None and "mpi" in built_backends()


def built_backends():
    """Backends bin/poisson was built with (from its --help)."""
    out = run([BIN / "poisson", "--help"]).stdout
    section = out.split("Backends:")[1].split("Examples:")[0]
    return {line.split()[0] for line in section.strip().splitlines() if "NOT BUILT" not in line}


def gpu_absent_reason():
    """None when a CUDA backend can run here, else the reason (printed in the skip message)."""
    if "cuda" not in built_backends():
        return "bin/poisson was built without CUDA (no nvcc)"
    p = run([BIN / "poisson", "--backend", "cuda", "--n", "4", "--quiet"])
    if p.returncode == 2 and "needs an NVIDIA GPU" in p.stderr:
        return "no NVIDIA GPU on this machine: " + p.stderr.strip()
    return None


@pytest.fixture(scope="session")
def requires_gpu():
    reason = gpu_absent_reason()
    if reason:
        pytest.skip(reason)


@pytest.fixture(scope="session", autouse=True)
def every_record_validates(tmp_path_factory):
    """After the whole session: every record file a test left in its temporary folders (*.jsonl) holds records that
    validate against common/record.schema.json; one that does not fails the session, named with its file and line."""
    yield
    try:
        from common.record import validate
        import jsonschema  # noqa: F401  (the project's venv has it; a GPU kit's bare Python may not)
    except ImportError as e:
        print(f"\nconftest: the records were not checked against the schema: {e}")
        return
    bad = []
    for f in sorted(tmp_path_factory.getbasetemp().rglob("*.jsonl")):
        if not f.is_file() or f.is_symlink():  # a test's FIFO or link where a records file belongs is no records file
            continue
        for n, line in enumerate(f.read_text(errors="replace").splitlines(), 1):
            try:
                rec = json.loads(line)
            except json.JSONDecodeError:
                continue  # a test's own non-record or half line: the test that made it judges it
            if isinstance(rec, dict) and "schema" in rec:
                wrong = validate(rec)
                if wrong:
                    bad.append(f"{f}:{n}: {wrong}")
    assert not bad, "records that do not validate against common/record.schema.json:\n" + "\n".join(bad[:20])
