"""Careless and hostile use (issue 16): outputs that must not be destroyed, inputs that are no files, loops that must
not hang or crash, memory that must be refused before it is taken, runner arguments that must not run anything.
Each case asserts the exit status, the one line on stderr and that nothing else on disk changed. Every device node,
FIFO and link is made by the test in its own folder, never the machine's own."""
import hashlib
import os
import shutil
import signal
import stat
import subprocess
import time

import pytest

from bench import ff_file
from conftest import BIN, MPI_ENV, ROOT, have_mpi, run

BOX = (ROOT / "radiosity" / "scenes" / "closed_box.xml").read_text()
TRI = """<scene><head><objectdef name="t"><triangleset name="t" emission="1,1,1" reflectivity=".5,.5,.5">
<triangle><vertex x="0" y="0" z="0"/><vertex x="1" y="0" z="0"/><vertex x="0" y="1" z="0"/></triangle>
</triangleset></objectdef></head><body><object name="t"/></body></scene>"""


def radiosity(*args, timeout=120, **kw):
    return run([BIN / "radiosity", *args], timeout=timeout, **kw)


def state(folder):
    """Every entry of a folder: its kind and, for a file, its content's hash (a symlink by its target)."""
    out = {}
    for p in sorted(folder.iterdir()):
        st = os.lstat(p)
        if stat.S_ISLNK(st.st_mode):
            out[p.name] = ("link", os.readlink(p))
        elif stat.S_ISREG(st.st_mode):
            out[p.name] = ("file", hashlib.sha256(p.read_bytes()).hexdigest())
        else:
            out[p.name] = ("other", stat.S_IFMT(st.st_mode))
    return out


@pytest.fixture
def box(tmp_path):
    (tmp_path / "box.xml").write_text(BOX)
    p = radiosity("formfactors", tmp_path / "box.xml", "-o", tmp_path / "box.ff", "--hemicube", "32", "--quiet")
    assert p.returncode == 0, p.stderr
    return tmp_path


def refused(p, *words):
    """Exit 2, one line on stderr holding every word."""
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 2 and len(lines) == 1, (p.returncode, p.stderr)
    assert all(w in lines[0] for w in words), lines[0]
    return lines[0]


def unchanged(folder, before, *args, **kw):
    """Runs bin/radiosity ARGS in folder and asserts it was refused and that nothing there changed."""
    p = radiosity(*args, cwd=folder, **kw)
    assert state(folder) == before
    return p


def test_an_output_naming_a_device_node_or_fifo_is_refused_and_left_alone(box):
    os.mkfifo(box / "fifo")
    made_node = True
    try:
        os.mknod(box / "mynull", 0o666 | stat.S_IFCHR, os.makedev(1, 3))
    except PermissionError:
        made_node = False
    before = state(box)
    if made_node:
        for opt in ("--png", "--output", "--record"):
            refused(unchanged(box, before, "solve", "box.xml", "--ff", "box.ff", opt, "mynull", "--quiet"), opt,
                    "mynull", "character device")
        refused(unchanged(box, before, "formfactors", "box.xml", "-o", "mynull", "--quiet"), "-o", "character device")
        p = run([BIN / "poisson", "--n", "8", "--solution", "mynull", "--quiet"], cwd=box)
        refused(p, "--solution", "character device")
    refused(unchanged(box, before, "solve", "box.xml", "--ff", "box.ff", "--png", "fifo", "--quiet", timeout=20),
            "FIFO")
    refused(unchanged(box, before, "solve", "box.xml", "--ff", "box.ff", "--png", ".", "--quiet"), "folder")
    assert state(box) == before


def test_an_output_naming_an_input_or_another_output_is_refused(box):
    (box / "h.jsonl").write_text('{"kept": true}\n')
    before = state(box)
    refused(unchanged(box, before, "formfactors", "box.xml", "-o", "box.xml", "--quiet"), "-o", "input")
    refused(unchanged(box, before, "solve", "box.xml", "--ff", "box.ff", "--png", "box.ff", "--quiet"), "--png", "input")
    refused(unchanged(box, before, "solve", "box.xml", "--ff", "box.ff", "--output", "box.xml", "--quiet"), "input")
    refused(unchanged(box, before, "solve", "box.xml", "--ff", "box.ff", "--png", "o", "--output", "o", "--quiet"),
            "also given as")
    p = run([BIN / "poisson", "--n", "8", "--record", "h.jsonl", "--solution", "h.jsonl", "--quiet"], cwd=box)
    refused(p, "also given as")
    assert state(box) == before


def test_a_symlink_is_written_through_and_an_unrelated_tmp_is_left_alone(box):
    (box / "real.png").write_text("old")
    os.symlink("real.png", box / "link.png")
    (box / "box.ff.tmp").write_text("not ours")
    (box / "link.png.tmp").write_text("not ours either")
    p = radiosity("solve", "box.xml", "--ff", "box.ff", "--png", "link.png", "--quiet", cwd=box)
    assert p.returncode == 0, p.stderr
    assert os.path.islink(box / "link.png") and (box / "real.png").read_bytes()[:4] == b"\x89PNG"
    p = radiosity("formfactors", "box.xml", "-o", "box.ff", "--hemicube", "16", "--quiet", cwd=box)
    assert p.returncode == 0, p.stderr
    assert (box / "box.ff.tmp").read_text() == "not ours" and (box / "link.png.tmp").read_text() == "not ours either"
    assert not [f for f in os.listdir(box) if f.startswith(".hpcgi-")]
    name = "n" * 248 + ".png"  # a legal name of 252 bytes: no suffix is added to it
    assert radiosity("solve", "box.xml", "--ff", "box.ff", "--png", name, "--quiet", cwd=box).returncode == 0


def test_outputs_are_checked_before_the_computation(box):
    before = state(box)
    t = time.time()
    refused(unchanged(box, before, "formfactors", "box.xml", "--divide", "0.01", "--hemicube", "512", "-o",
                      "nodir/out.ff", "--quiet"), "nodir", "does not exist")
    assert time.time() - t < 5  # the hemicube of 1200 patches at R = 512 did not run first


def test_inputs_that_are_no_files_are_refused_without_blocking(box):
    os.mkfifo(box / "fifo")
    before = state(box)
    refused(unchanged(box, before, "solve", "box.xml", "--ff", "fifo", "--quiet", timeout=20), "--ff", "FIFO")
    refused(unchanged(box, before, "solve", "fifo", "--ff", "box.ff", "--quiet", timeout=20), "FIFO")
    refused(unchanged(box, before, "solve", "box.xml", "--ff", ".", "--quiet"), "--ff", "folder")
    refused(unchanged(box, before, "solve", "box.xml", "--ff", "box.ff", "--record", "fifo", "--quiet", timeout=20),
            "--record", "FIFO")


def test_deep_nesting_duplicate_attributes_and_trailing_text_are_refused(tmp_path):
    i, j = BOX.index("<body>"), BOX.index("</body>")
    n = 16000
    deep = BOX[:i] + "<body>" + '<translate dx="0">' * n + '<object name="box"/>' + "</translate>" * n + BOX[j:]
    cases = {"deep.xml": (deep, "nested more than 1000 deep"),
             "dup.xml": (BOX.replace('<triangleset name="box"', '<triangleset name="box" name="b2"', 1), "twice"),
             "after.xml": (BOX + "text after the root", "text outside the root element")}
    for name, (xml, why) in cases.items():
        (tmp_path / name).write_text(xml)
        line = refused(radiosity("info", tmp_path / name), why)
        assert f"{name}:" in line  # with the line of the element
    big = BOX.replace('name="box"', 'name="' + "x" * 10_000_000 + '"', 1).replace("<object name=\"box\"", "<object name=\"y\"")
    (tmp_path / "big.xml").write_text(big)
    p = radiosity("info", tmp_path / "big.xml")
    assert p.returncode == 2 and len(p.stderr) < 1000, len(p.stderr)


def test_more_mpi_ranks_than_patches_are_refused_not_deadlocked(tmp_path):
    if not have_mpi():
        pytest.skip("bin/radiosity was built without MPI")
    (tmp_path / "tri.xml").write_text(TRI)
    assert radiosity("formfactors", tmp_path / "tri.xml", "-o", tmp_path / "tri.ff", "--quiet").returncode == 0
    for args in (["solve", tmp_path / "tri.xml", "--ff", tmp_path / "tri.ff", "--backend", "mpi", "--steps", "2"],
                 ["formfactors", tmp_path / "tri.xml", "-o", tmp_path / "tri2.ff"]):
        p = run(["mpirun", "-np", "2", BIN / "radiosity", *args, "--quiet"], env=MPI_ENV, timeout=60)
        assert p.returncode == 2 and "1 patch for 2 MPI ranks" in p.stderr, p.stderr
    assert not (tmp_path / "tri2.ff").exists()


def test_two_formfactors_on_one_output_both_succeed_and_leave_one_whole_file(box):
    cmds = [[BIN / "radiosity", "formfactors", box / "box.xml", "--divide", "0.05", "-o", box / "same.ff",
             "--hemicube", str(r), "--quiet"] for r in (16, 18)]
    procs = [subprocess.Popen([str(c) for c in cmd], stderr=subprocess.PIPE, text=True) for cmd in cmds]
    assert [p.wait(timeout=120) for p in procs] == [0, 0], [p.stderr.read() for p in procs]
    header, _ = ff_file.read(box / "same.ff")
    assert header["resolution"] in (16, 18)  # the data of one run that reported success, whole
    p = radiosity("solve", box / "box.xml", "--divide", "0.05", "--ff", box / "same.ff", "--quiet")
    assert p.returncode == 0, p.stderr
    assert not [f for f in os.listdir(box) if f.startswith(".hpcgi-")]


def test_sigterm_while_computing_form_factors_leaves_nothing(box):
    before = state(box)
    p = subprocess.Popen([str(BIN / "radiosity"), "formfactors", "box.xml", "--divide", "0.002", "--hemicube", "256",
                          "-o", "out.ff", "--quiet"], cwd=box)
    time.sleep(1.0)
    p.send_signal(signal.SIGTERM)
    assert p.wait(timeout=30) == -signal.SIGTERM
    assert state(box) == before


def test_form_factor_values_out_of_range_are_refused(box):
    header, values = ff_file.read(box / "box.ff")
    n = header["n"]
    for edit, why in ((lambda v: v.__setitem__(1, -5.0), "lies in [0, 1]"),
                      (lambda v: v.__setitem__(0, 0.9), "to itself must be 0")):
        v = list(values)
        edit(v)
        ff_file.rewrite(box / "bad.ff", header, v)
        refused(radiosity("solve", box / "box.xml", "--ff", box / "bad.ff", "--quiet"), why, "F[0]")
    assert n == 12
    p = radiosity("formfactors", box / "box.xml", "--divide", "0.1", "--hemicube", "2", "-o", box / "coarse.ff")
    assert p.returncode == 0 and "note: a row of F sums to 1.13" in p.stdout, p.stdout


def test_tolerances_thresholds_and_snapshots_that_make_no_answer_are_refused(box):
    s = ["solve", box / "box.xml", "--ff", box / "box.ff", "--quiet"]
    refused(radiosity(*s, "--tol", "1e-300"), "below what float can reach")
    refused(radiosity(*s, "--tol", "1e-300", "--precision", "double"), "below what double can reach")
    refused(radiosity(*s, "--tol", "1"), "below 1")
    refused(radiosity(*s, "--tol", "-1"), "--tol -1", "finite number > 0")
    # relight's frames by the same rules (check_config), before anything is read
    r = ["relight", box / "box.xml", "--ff", box / "box.ff", "--random-frames", "2", "--quiet"]
    refused(radiosity(*r, "--tol", "2"), "below 1")
    refused(radiosity(*r, "--tol", "1e-300"), "below what float can reach")
    refused(run([BIN / "poisson", "--n", "8", "--tol", "2"]), "below 1")
    for t in ("nan", "1", "-0.1"):
        refused(radiosity(*s, "--threshold", t), "--threshold", "from 0 to below 1")
    refused(radiosity(*s, "--snapshots", "1000000000", "--steps", "4"), "no such iteration")


def test_memory_is_refused_before_it_is_taken(box):
    s = ["--max-memory-per-rank", "1G", "--quiet"]
    refused(radiosity("formfactors", box / "box.xml", "-o", box / "x.ff", "--hemicube", "16384", *s), "more than")
    refused(radiosity("solve", box / "box.xml", "--ff", box / "box.ff", "--png", box / "x.png", "--size",
                      "16384x16384", *s), "more than")
    refused(radiosity("solve", box / "box.xml", "--ff", box / "box.ff", "--threads", "4096"), "--threads 4096")
    assert not (box / "x.ff").exists() and not (box / "x.png").exists()


def test_messages_are_readable(box):
    line = refused(radiosity("solve", box / "box.xml", "--ff", box / "box.ff", "--max-iter", "0"))
    assert "from 1 to" in line and len(line) < 200
    assert "'16abc' is not an integer" in refused(run([BIN / "poisson", "--n", "16abc"]))
    assert "unknown subcommand 'bogus'" in refused(radiosity("bogus"))


def runner(*args, env):
    return run([ROOT / "slurm" / args[0], *args[1:]], env=env, timeout=300)


def test_runner_arguments_are_validated_and_never_evaluated(tmp_path):
    e = {"RESULTS": str(tmp_path / "results"), "FF_DIR": str(tmp_path / "ff dir"), "PRESET": "ci", "MACHINE": "t"}
    pwned = tmp_path / "pwned"
    for index in (f"x[$(touch {pwned})]", "abc", "-1", "999"):
        for dry in ("0", "1"):
            p = runner("run-case", "table41", index, env={**e, "DRY_RUN": dry})
            assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert not pwned.exists()
    for rep in ("-3", "abc", "0"):
        p = runner("run-case", "table41", "0", env={**e, "REPEAT": rep})
        assert p.returncode == 2 and "REPEAT must be a positive integer" in p.stderr
    p = runner("run-local", env=e)
    assert p.returncode == 2 and "usage" in p.stderr
    # a folder with a space stays one argument
    p = runner("run-local", "formfactors", "table42", env={**e, "REPEAT": "1"})
    assert p.returncode == 0, p.stdout + p.stderr
    assert (tmp_path / "ff dir" / "ci-scene1.ff").exists()


def test_two_launches_of_one_case_record_it_once(tmp_path):
    """A resubmission while the first task runs: the second waits for the first's lock, then finds it recorded."""
    e = dict(os.environ, RESULTS=str(tmp_path / "results"), FF_DIR=str(tmp_path / "ff"), PRESET="ci", MACHINE="t",
             REPEAT="1")

    def twice(exp, index):
        procs = [subprocess.Popen([str(ROOT / "slurm" / "run-case"), exp, str(index)], env=e, cwd=ROOT,
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for _ in range(2)]
        outs = [p.communicate(timeout=300) for p in procs]
        assert [p.returncode for p in procs] == [0, 0], outs
        assert sum("already recorded" in o for o, _ in outs) == 1, outs
        return (tmp_path / "results" / "t" / exp / "ci.jsonl").read_text().splitlines()

    assert len(twice("formfactors", 0)) == 1  # writes -o ci-scene1.ff: the second found it made and recorded
    assert len(twice("table42", 0)) == 1      # reads it
