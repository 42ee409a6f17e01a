"""The helpers of the MPI radiosity tests (test_mpi_radiosity.py, test_mpi_radiosity_sparse.py, test_multinode.py):
bin/radiosity under mpirun, its record and its solved scene, and the form-factor files of an odd scene written by
the serial program and by P = 1..4 ranks, made once per session."""
import json
import shutil
import xml.etree.ElementTree as ET

import numpy as np

from conftest import BIN, MPI_ENV, ROOT, run

SCENES = ROOT / "radiosity" / "scenes"


def mpi_built():
    if not shutil.which("mpirun"):
        return False
    p = run(["mpirun", "-np", "1", BIN / "radiosity", "solve", SCENES / "scene1.xml", "--ff", "/nonexistent",
             "--backend", "mpi"], env=MPI_ENV, timeout=60)
    return p.returncode == 2 and "cannot open" in p.stderr


MPI_BUILT = mpi_built()

HEMICUBE = ["--hemicube", "32"]


def odd_scene(directory):
    """scene1 with one small triangle more: 1313 patches, an odd count, so that rows of 4n bytes end inside a 64-bit
    word of the checksum and the ranks' chained checksum must carry the unfinished word from rank to rank."""
    s = (SCENES / "scene1.xml").read_text()
    i = s.index("</objectdef>")
    s = s[:i] + ('<triangleset name="odd" reflectivity=".3,.3,.3"><triangle><vertex x="0" y="3" z="0"/>'
                 '<vertex x="0.5" y="3" z="0"/><vertex x="0" y="3" z="0.5"/></triangle></triangleset>\n') + s[i:]
    path = directory / "odd.xml"
    path.write_text(s)
    return path


def messages(p):
    """The program's own lines on stderr (mpirun adds its report of a non-zero exit status)."""
    return [l for l in p.stderr.splitlines() if l.startswith("radiosity:")]


def radiosity(*args, np_=None, timeout=300):
    cmd = [BIN / "radiosity", *args]
    if np_ is not None:
        return run(["mpirun", "-np", str(np_), *cmd], env=MPI_ENV, timeout=timeout)
    return run(cmd, timeout=timeout)


def record(p):
    assert p.returncode == 0, p.stderr
    lines = [l for l in p.stdout.splitlines() if l.startswith("{")]
    assert len(lines) == 1, f"one record on stdout (rank 0's), got {len(lines)}: {p.stdout[:400]}"
    return json.loads(lines[0])


def radiosities(path):
    tris = ET.parse(path).getroot().iter("triangle")
    return np.array([[float(c) for c in t.get("radiosity").split(",")] for t in tris])


def rel_diff(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


_FILES = []  # form_factor_files' one answer


def form_factor_files(tmp_path_factory):
    """scene1 (odd patch count): the serial program's form-factor file and those of P = 1..4 ranks, made once per
    test session for every module that asks (the `files` fixture of test_mpi_radiosity*.py)."""
    if _FILES:
        return _FILES[0]
    d = tmp_path_factory.mktemp("mpi")
    scene = odd_scene(d)
    serial = d / "serial.ff"
    rec = record(radiosity("formfactors", scene, *HEMICUBE, "-o", serial, "--json", "--quiet"))
    assert rec["params"]["patches"] % 2 == 1
    out = {"serial": (serial, rec), "scene": scene}
    for p in (1, 2, 3, 4):
        f = d / f"P{p}.ff"
        r = record(radiosity("formfactors", scene, *HEMICUBE, "-o", f, "--json", "--quiet", np_=p))
        out[p] = (f, r)
    _FILES.append((d, out))
    return d, out
