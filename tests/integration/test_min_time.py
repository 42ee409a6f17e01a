"""--min-time (common/repetitions.hpp, issue 49): a short solve timed as the median of its repetitions in one process.
The answer is the same as one solve's (every repetition solves the same system from the same start), the record's
times are the chosen repetition's, its "repetitions" section validates and sums to the minimum time, and an option
that would repeat a side effect (--snapshots) is refused. No test here reads how long anything took against a bound."""
import json

import pytest

from common.record import validate
from conftest import BIN, ROOT, have_mpi, poisson, run

SCENE = ROOT / "radiosity" / "scenes" / "scene1.xml"


def radiosity(*args):
    return run([BIN / "radiosity", *map(str, args)], timeout=300)


@pytest.fixture(scope="module")
def ff(tmp_path_factory):
    f = tmp_path_factory.mktemp("mt") / "scene1.ff"
    p = radiosity("formfactors", SCENE, "-o", f, "--hemicube", "32", "--quiet")
    assert p.returncode == 0, p.stderr
    return f


def solve(ff, *extra):
    p = radiosity("solve", SCENE, "--ff", ff, "--tol", "1e-6", "--backend", "openmp", "--threads", "2", "--json",
                  "--quiet", *extra)
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout)


def check_section(rec, min_time, ranks=1):
    r = rec["repetitions"]
    assert validate(rec) is None
    assert r["min_time_s"] == min_time and r["count"] == len(r["times_s"]) >= 1
    t = rec["times_s"]
    if ranks == 1:
        assert r["times_s"][r["chosen"]] == pytest.approx(t["setup"] + t["solve"], rel=1e-9, abs=1e-12)
    else:  # the slowest rank's time decides; the record's times are rank 0's
        assert r["times_s"][r["chosen"]] >= (t["setup"] + t["solve"]) * (1 - 1e-9)
    if r["warmup_s"] is None:  # one run as long as the minimum: the answer alone
        assert r["count"] == 1 and r["times_s"][0] >= min_time
    else:
        assert r["warmup_s"] < min_time and sum(r["times_s"]) >= min_time
        below = sum(x < r["times_s"][r["chosen"]] for x in r["times_s"])
        assert below == (r["count"] - 1) // 2  # the lower median (times are distinct in practice; ties would lower it)
    return r


def test_radiosity_repetitions_give_the_same_answer_and_the_median_time(ff):
    one = solve(ff)
    many = solve(ff, "--min-time", "0.05")
    assert "repetitions" not in one
    check_section(many, 0.05)
    # the same system from the same start: the same iterations and residuals, bit for bit on the same threads
    assert many["result"]["iterations"] == one["result"]["iterations"]
    assert many["result"]["rel_residual"] == one["result"]["rel_residual"]


def test_radiosity_refuses_min_time_with_snapshots(ff, tmp_path):
    p = radiosity("solve", SCENE, "--ff", ff, "--min-time", "0.1", "--snapshots", "1",
                  "--snapshot-prefix", tmp_path / "s")
    assert p.returncode == 2 and "--min-time repeats the solve" in p.stderr
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("bad", ["-1", "nan", "inf", "3601", "x"])
def test_min_time_refuses_what_is_no_time(ff, bad):
    for cmd in ([BIN / "poisson", "--n", "8"], [BIN / "radiosity", "solve", SCENE, "--ff", ff]):
        p = run([*map(str, cmd), f"--min-time={bad}"], timeout=60)
        assert p.returncode == 2 and p.stderr.count("\n") == 1 and "--min-time" in p.stderr, (bad, p.stderr)


def test_poisson_repetitions_give_the_same_answer(tmp_path):
    _, one = poisson("--n", "64", "--backend", "openmp", "--threads", "2")
    _, many = poisson("--n", "64", "--backend", "openmp", "--threads", "2", "--min-time", "0.05")
    check_section(many, 0.05)
    assert many["result"]["iterations"] == one["result"]["iterations"]
    assert many["result"]["error_inf"] == one["result"]["error_inf"]


@pytest.mark.skipif(not have_mpi(), reason="bin/poisson was built without MPI, or mpirun is missing")
def test_poisson_ranks_repeat_together():
    p, rec = poisson("--n", "64", "--backend", "mpi", "--min-time", "0.05", np=2)
    assert p.returncode == 0, p.stderr
    check_section(rec, 0.05, ranks=2)
