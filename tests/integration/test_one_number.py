"""One quantity, one number (issue 34): a report built from records in which one quantity (scene 1's Jacobi solve,
quoted by Table 4.2 and by Table 4.3's OpenMP column) is planted at different values fails, naming both places;
without the plant it is written."""
import json
import subprocess
import sys

from conftest import ROOT, run

REF = (ROOT / "results" / "REFERENCE").read_text().strip()
HEAD = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip()


def fixture(tmp_path, factor):
    """Five clean runs of scene 1's OpenMP Jacobi solve as Table 4.2's records (copies of one reference record: the
    reference's adaptive repeats may have stopped at fewer), and the same runs (times x factor) as Table 4.3's OpenMP
    column."""
    src = [json.loads(l) for l in (ROOT / "results" / REF / "table42" / "quick.jsonl").read_text().splitlines()]
    one = next(r for r in src if r["params"]["scene"].endswith("scene1.xml") and r["params"]["method"] == "jacobi")
    runs = [one] * 5
    res = tmp_path / "results"
    for exp, f in (("table42", 1.0), ("table43", factor)):
        out = []
        for i, r in enumerate(runs):
            r = json.loads(json.dumps(r))
            r["provenance"].update(git_commit=HEAD, git_dirty=False)
            r["provenance"]["env"].update(HPCGI_CASE=f"ci/{exp}/0/x", HPCGI_REPEAT=str(i), HPCGI_EXPERIMENT=exp)
            r["times_s"].update(setup=0.001 * f, solve=(0.010 + 0.0001 * i) * f)
            out.append(json.dumps(r))
        (res / "m" / exp).mkdir(parents=True)
        (res / "m" / exp / "ci.jsonl").write_text("\n".join(out) + "\n")
    return {"RESULTS": str(res)}


def analysis(env, *args):
    return run([sys.executable, "-m", "analysis", *args, "ci", "--machine", "m"], env=env, cwd=ROOT, timeout=300)


def test_a_planted_disagreement_fails_generation_and_names_both_places(tmp_path):
    env = fixture(tmp_path / "planted", 3.0)
    t = analysis(env, "tables")
    assert t.returncode == 1
    p = analysis(env, "report")
    assert p.returncode == 1 and "no report written" in p.stderr
    assert "Table 4.2 (ci), scene 1, ours jacobi s" in p.stderr and "Table 4.3 (ci), scene 1, ours openmp" in p.stderr
    assert not (tmp_path / "planted" / "results" / "report" / "m" / "REPORT-ci.md").exists()


def test_without_the_plant_the_report_is_written(tmp_path):
    env = fixture(tmp_path / "clean", 1.0)
    assert analysis(env, "tables").returncode == 0
    p = analysis(env, "report")
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "clean" / "results" / "report" / "m" / "REPORT-ci.md").exists()
