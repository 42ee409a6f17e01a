"""The record's one definition, common/record.schema.json: every producer's record validates against it (bin/poisson,
bin/radiosity's subcommands, bin/stream, the Python peers), so do the committed records, and `make plots` names a
record that does not (its file and line) and leaves it out instead of using it. (tests/conftest.py checks every
record file the other tests leave behind as well.)"""
import json
import subprocess
import sys

import jsonschema
import pytest

from common.record import DEFINITION, ENV_KEYS, SCHEMA
from common.record import validate
from conftest import BIN, ROOT, run

SCENE = ROOT / "radiosity" / "scenes" / "scene1.xml"


def records_of(*cmd):
    p = run([*cmd, "--json", "--quiet"], cwd=ROOT, timeout=300)
    assert p.returncode == 0, p.stderr
    return [json.loads(l) for l in p.stdout.splitlines() if l.startswith("{")]


def test_the_schema_is_a_valid_json_schema_and_its_version_is_the_records():
    jsonschema.Draft202012Validator.check_schema(DEFINITION)
    assert SCHEMA == "hpcgi-record/1" and "HPCGI_CASE" in ENV_KEYS and "OPENBLAS_NUM_THREADS" in ENV_KEYS


@pytest.fixture(scope="module")
def ff(tmp_path_factory):
    f = tmp_path_factory.mktemp("schema") / "s.ff"
    assert run([BIN / "radiosity", "formfactors", SCENE, "--hemicube", "16", "-o", f, "--quiet"]).returncode == 0
    return f


def test_every_producer_validates(ff, tmp_path):
    produced = {
        "poisson": records_of(BIN / "poisson", "--n", "16"),
        "poisson --steps": records_of(BIN / "poisson", "--n", "16", "--steps", "3"),
        "stream": records_of(BIN / "stream", "--size", str(1 << 12), "--trials", "2"),
        "radiosity info": records_of(BIN / "radiosity", "info", SCENE),
        "radiosity formfactors": records_of(BIN / "radiosity", "formfactors", SCENE, "--hemicube", "8", "-o",
                                            tmp_path / "x.ff"),
        "radiosity solve": records_of(BIN / "radiosity", "solve", SCENE, "--ff", ff, "--tol", "1e-4"),
        "radiosity solve --steps": records_of(BIN / "radiosity", "solve", SCENE, "--ff", ff, "--steps", "4",
                                              "--method", "gauss-seidel"),
        "peer scipy-cg": records_of(sys.executable, "-m", "bench.peers", "scipy-cg", "--n", "16", "--threads", "1"),
    }
    for what, recs in produced.items():
        assert len(recs) == 1, what
        assert validate(recs[0]) is None, (what, validate(recs[0]))
    # and a record that is no answer (exit 4) still validates, with its status
    p = run([BIN / "poisson", "--n", "64", "--max-iter", "2", "--json", "--quiet"])
    assert p.returncode == 4
    rec = json.loads(p.stdout)
    assert validate(rec) is None and rec["result"]["exit_status"] == 4


def test_the_schema_refuses_what_is_no_record():
    rec = records_of(BIN / "poisson", "--n", "8")[0]
    for broken, where in ((dict(rec, schema="hpcgi-record/2"), "schema"), ({k: v for k, v in rec.items() if k != "provenance"}, "the record"),
                          (dict(rec, times_s={"solve": "fast"}), "times_s/solve"),
                          (dict(rec, result=dict(rec["result"], exit_status=7)), "result/exit_status")):
        wrong = validate(broken)
        assert wrong and wrong.startswith(where), (where, wrong)


def test_committed_records_validate():
    bad = []
    files = [f for f in sorted((ROOT / "results").rglob("*.jsonl")) if not f.name.endswith(".state.jsonl")]
    assert files
    for f in files:
        for n, line in enumerate(f.read_text().splitlines(), 1):
            wrong = validate(json.loads(line))
            if wrong:
                bad.append(f"{f}:{n}: {wrong}")
    assert not bad, bad[:5]


def test_make_plots_names_a_record_that_does_not_validate(tmp_path):
    """A hand-broken record in a results file: `make plots` says which file and line, leaves it out, exits 1."""
    res = tmp_path / "results" / "schema-test"
    f = res / "table41" / "ci.jsonl"
    f.parent.mkdir(parents=True)
    good = records_of(BIN / "poisson", "--n", "16")[0]
    broken = dict(good, times_s=dict(good["times_s"], solve=-1.0))
    f.write_text(json.dumps(good) + "\n" + json.dumps(broken) + "\n")
    p = subprocess.run(["make", "-s", "plots", "PRESET=ci", "MACHINE=schema-test"], cwd=ROOT, capture_output=True,
                       text=True, timeout=300, env={**__import__("os").environ, "RESULTS": str(tmp_path / "results"),
                            "ANALYSIS_ALL_RECORDS": "1"})
    try:
        assert p.returncode != 0, p.stdout + p.stderr
        assert f"{f}:2: not a valid hpcgi-record/1 record, left out: times_s/solve:" in p.stderr, p.stderr
        assert f"{f}:1" not in p.stderr
        assert "analysis: table41 (ci, schema-test): written" in p.stdout, p.stdout
    finally:
        f.unlink()  # the session's own check of every record file (conftest.py) is for what the programs wrote
