"""The --ff file's header is parsed once per process (issue 36, item 2): the load reads and checks it once and hands
what it says to every reader of the values (dense, a sparse file, an MPI rank's rows, read again when the rows are
balanced by cost). A test-only hook counts the parses: HPCGI_TEST_FF_HEADER_LOG names a file to which every parse of
a form-factor header appends "PID PATH" (radiosity/formfactor/file/format.hpp, kHeaderReadLogEnv)."""
import collections
import shutil

import pytest

from conftest import BIN, MPI_ENV, ROOT, have_mpi, run

SCENE = ROOT / "radiosity" / "scenes" / "scene1.xml"
HOOK = "HPCGI_TEST_FF_HEADER_LOG"


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("ff_header_once")
    for storage in ("dense", "csr"):
        p = run([BIN / "radiosity", "formfactors", SCENE, "-o", d / f"{storage}.ff", "--hemicube", "16",
                 "--storage", storage, "--quiet"])
        assert p.returncode == 0, p.stderr
    return d


def parses(log, path):
    """Header parses of `path` per process id, from the hook's log."""
    per_pid = collections.Counter()
    for line in log.read_text().splitlines():
        pid, _, parsed = line.partition(" ")
        if parsed == str(path):
            per_pid[pid] += 1
    return per_pid


def solve(files, tmp_path, ff, *args, np_=None):
    log = tmp_path / "headers.log"
    cmd = [BIN / "radiosity", "solve", SCENE, "--ff", files / ff, "--quiet", "--threads", "1", *args]
    env = {HOOK: str(log)}
    if np_:
        cmd = ["mpirun", "-np", str(np_), *cmd]
        env.update(MPI_ENV)
    p = run(cmd, env=env)
    assert p.returncode == 0, p.stderr
    return parses(log, files / ff)


@pytest.mark.parametrize("args", [[], ["--storage", "csr"], ["--ff-precision", "float16", "--storage", "dense"],
                                  ["--threshold", "1e-3"]], ids=["dense", "to-csr", "to-float16", "threshold"])
def test_a_dense_file_is_parsed_once(files, tmp_path, args):
    per_pid = solve(files, tmp_path, "dense.ff", *args)
    assert list(per_pid.values()) == [1], per_pid


def test_a_sparse_file_is_parsed_once(files, tmp_path):
    per_pid = solve(files, tmp_path, "csr.ff")
    assert list(per_pid.values()) == [1], per_pid


@pytest.mark.skipif(not have_mpi() or not shutil.which("mpirun"), reason="no MPI build or no mpirun")
@pytest.mark.parametrize("storage", ["dense", "csr"])
def test_each_mpi_rank_parses_it_once(files, tmp_path, storage):
    """csr: the ranks read their rows a second time once balanced by cost, without parsing the header again."""
    per_pid = solve(files, tmp_path, "dense.ff", "--backend", "mpi", "--storage", storage, np_=2)
    assert sorted(per_pid.values()) == [1, 1], per_pid


def test_the_hook_counts_every_parse(files, tmp_path):
    """The hook itself: --reference-ff on a copy of the file is a second file, parsed once too; the count sees both."""
    shutil.copy(files / "dense.ff", tmp_path / "copy.ff")
    log = tmp_path / "headers.log"
    p = run([BIN / "radiosity", "solve", SCENE, "--ff", files / "dense.ff", "--reference-ff", tmp_path / "copy.ff",
             "--quiet", "--threads", "1"], env={HOOK: str(log)})
    assert p.returncode == 0, p.stderr
    assert list(parses(log, files / "dense.ff").values()) == [1]
    assert list(parses(log, tmp_path / "copy.ff").values()) == [1]
