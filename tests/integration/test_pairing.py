"""The runner pairs what the claims compare (issue 49): the timed experiments of one block ("# block: NAME" in their
lists) run in joint rounds, every case's repeat r before any case's repeat r + 1, the order reversed from one round
to the next; every state line names its block, so that the claims take a round's two runs as a pair."""
import json

from conftest import ROOT, run


def test_a_block_runs_its_experiments_in_joint_rounds_the_order_alternating(tmp_path):
    e = {"RESULTS": str(tmp_path / "results"), "FF_DIR": str(tmp_path / "ff"), "PRESET": "ci", "REPEAT": "2",
         "MACHINE": "pairs", "HPCGI_STATE_DIR": str(tmp_path / "state"), "HPCGI_PROBE": ""}
    assert run([ROOT / "slurm" / "run-local", "formfactors"], env=e, timeout=600).returncode == 0
    p = run([ROOT / "slurm" / "run-local", "table43", "table42"], env=e, timeout=900)
    assert p.returncode == 0, p.stdout + p.stderr
    assert "block radiosity-cpu (ci: table43 table42)" in p.stdout, p.stdout
    lines = []
    for exp in ("table42", "table43"):
        for l in (tmp_path / "results" / "pairs" / exp / "ci.state.jsonl").read_text().splitlines():
            s = json.loads(l)
            if "repeat" in s:
                lines.append((s["utc"], s["wall_s"], exp, s["case"], s["repeat"], s["block"]))
    assert lines and all(b == "radiosity-cpu" for *_, b in lines)
    # the runs in the order they ran: round 1 (repeat 0) wholly before round 2, and round 2 in the reverse order
    ran = [l.split("run-case: ")[1].split(" repeat ")[0] + f"/{l.split(' repeat ')[1].split(':')[0]}"
           for l in p.stdout.splitlines() if l.startswith("run-case: ") and " repeat " in l and ": bin/" in l]
    first = [r.rsplit("/", 1)[0] for r in ran if r.endswith("/0")]
    second = [r.rsplit("/", 1)[0] for r in ran if r.endswith("/1")]
    assert ran.index(next(r for r in ran if r.endswith("/1"))) == len(first), ran
    # a case skipped in round 1 (a GPU case here) leaves the rounds; the others run again, in the reverse order
    assert second == [c for c in reversed(first) if c in second] and len(second) >= len(first) - 1, (first, second)
    assert {c.split("/")[1] for c in second} == {"table42", "table43"}
