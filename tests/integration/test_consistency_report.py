"""One quantity, one number (issue 34): a report built from a small fixture of records in which the same quantity,
room3's OpenMP Jacobi solve (AOS, the same settings), is quoted by Table 4.2 and Table 4.3. With one planted
disagreement (Table 4.3's runs three times slower) `python -m analysis tables` and `report` fail and name both
places, and no report is written; without the plant both pass and the report is written."""
import json
import os
import subprocess
import sys

import pytest

from conftest import ROOT

REFERENCE = ROOT / "results" / "vm-amd-epyc-2c"


def scene3_jacobi():
    """The reference machine's committed Table 4.2 records of room3's OpenMP AOS Jacobi solve (the fixture)."""
    out = []
    for line in (REFERENCE / "table42" / "quick.jsonl").read_text().splitlines():
        rec = json.loads(line)
        p = rec.get("params", {})
        if (str(p.get("scene", "")).endswith("room3.xml") and p.get("method") == "jacobi"
                and p.get("backend") == "openmp" and p.get("layout") == "aos" and rec.get("exit_status", 0) == 0):
            out.append(rec)
    return out


def make_results(tmp_path, factor):
    """results/fixture/: table42 with the room3 Jacobi runs, table43 with the same runs, their times times factor."""
    runs = scene3_jacobi()
    assert len(runs) >= 3, "the fixture needs 3 runs of room3's Jacobi in the committed table42 records"
    res = tmp_path / "results"
    for exp, f in (("table42", 1.0), ("table43", factor)):
        d = res / "fixture" / exp
        d.mkdir(parents=True)
        lines = []
        for rec in runs:
            rec = json.loads(json.dumps(rec))
            for k in ("setup", "solve", "per_iteration"):
                if isinstance(rec["times_s"].get(k), (int, float)):
                    rec["times_s"][k] *= f
            lines.append(json.dumps(rec))
        (d / "quick.jsonl").write_text("\n".join(lines) + "\n")
    return res


def analysis(res, command):
    env = dict(os.environ, RESULTS=str(res), MACHINE="fixture", ANALYSIS_ALL_RECORDS="1")
    return subprocess.run([sys.executable, "-m", "analysis", command, "quick"], cwd=ROOT, env=env, capture_output=True,
                          text=True, timeout=300)


@pytest.mark.parametrize("factor", [1.0, 3.0])
def test_a_planted_disagreement_fails_generation_and_names_both_places(tmp_path, factor):
    res = make_results(tmp_path, factor)
    tables, report = analysis(res, "tables"), analysis(res, "report")
    written = res / "report" / "fixture" / "REPORT-quick.md"
    places = ("Table 4.2 (quick), scene 3, ours jacobi s", "Table 4.3 (quick), scene 3, ours openmp")
    quotes = json.loads((res / "fixture" / "tables" / "quotes_quick.json").read_text())
    assert {q["where"] for q in quotes} >= set(places)  # the same quantity quoted in both tables
    if factor == 1.0:
        assert tables.returncode == 0, tables.stderr
        assert report.returncode == 0, report.stderr
        assert written.exists() and "Table 4.3 (quick)" in written.read_text()
    else:
        assert tables.returncode == 1 and report.returncode == 1, tables.stderr + report.stderr
        for err in (tables.stderr, report.stderr):
            assert "one quantity, two numbers" in err and all(p in err for p in places), err
        assert "no report written" in report.stderr and not written.exists()
