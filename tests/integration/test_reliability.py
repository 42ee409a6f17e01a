"""Bad input and numerical failure through bin/radiosity, as a user or a job array meets them: every case ends
with its exit status (2 bad input, 3 numerical failure, 4 not converged, 5 disagreed), one line on stderr, a record that says what happened
(for a failed solve) and no half-made output. The table of docs/reliability.md ("Reliability: bad input and faults") is made
from these cases.

The form-factor files that make a solve go wrong are made by tests/ff_file.py from a real file of the scene:
values changed, checksum recomputed, so the reader accepts them and the solver's guards must catch them."""
import json
import math

import pytest

from bench import ff_file
from conftest import BIN, ROOT, run

# Two triangles facing each other (z = 0 up, z = 1 down), area 0.5 each: the smallest scene with a free F.
TWO = """<scene><head><objectdef name="o"><triangleset {attrs}>
<triangle><vertex x="0" y="0" z="0"/><vertex x="1" y="0" z="0"/><vertex x="0" y="1" z="0"/></triangle>
<triangle><vertex x="0" y="0" z="1"/><vertex x="0" y="1" z="1"/><vertex x="1" y="0" z="1"/></triangle>
</triangleset></objectdef></head><body><object name="o"/></body></scene>"""

BOX = (ROOT / "radiosity" / "scenes" / "closed_box.xml").read_text()


def radiosity(*args):
    return run([BIN / "radiosity", *args], timeout=300)


def scene_with_ff(tmp_path, xml, edit=None):
    """The scene written to tmp_path, its real form factors, and (if edit) a copy with edit(values) -> values."""
    scene = tmp_path / "scene.xml"
    scene.write_text(xml)
    ff = tmp_path / "scene.ff"
    p = radiosity("formfactors", scene, "--allow-reflectivity-ge-1", "--hemicube", "32", "-o", ff, "--quiet")
    assert p.returncode == 0, p.stderr
    if edit:
        header, values = ff_file.read(ff)
        ff_file.rewrite(ff, header, edit(values))
    return scene, ff


def failed_solve(tmp_path, scene, ff, *args):
    """Runs a solve that must fail numerically: exit 3, one line, a record, no scene or picture written."""
    rec, out, png = tmp_path / "rec.jsonl", tmp_path / "out.xml", tmp_path / "out.png"
    p = radiosity("solve", scene, "--allow-reflectivity-ge-1", "--ff", ff, "--record", rec, "--output", out,
                  "--png", png, "--size", "16x16", *args)
    assert p.returncode == 3, (p.returncode, p.stdout, p.stderr)
    assert len(p.stderr.strip().splitlines()) == 1 and p.stderr.startswith("radiosity: numerical failure: "), p.stderr
    assert not out.exists() and not png.exists()
    lines = rec.read_text().splitlines()
    assert len(lines) == 1
    r = json.loads(lines[0])
    assert r["result"]["converged"] is False and r["verify"]["agreed"] is None
    assert r["result"]["detail"] in p.stderr
    return r["result"], p.stderr


# ρ = 1 in a closed box, F scaled by 1.5: every row of ρF sums to 1.5, Jacobi's iterates grow by 1.5 per step.
@pytest.mark.parametrize("args", [["--tol", "1e-6"], ["--steps", "100"], ["--steps", "100", "--backend", "original"],
                                  ["--tol", "1e-6", "--precision", "double", "--layout", "soa"]])
def test_divergent_jacobi_exits_3_with_a_record(tmp_path, args):
    scene, ff = scene_with_ff(tmp_path, BOX.replace('reflectivity=".5,.5,.5"', 'reflectivity="1,1,1"'),
                              lambda v: [1.5 * x for x in v])
    result, err = failed_solve(tmp_path, scene, ff, *args)
    assert result["status"] == "divergent" and "divergent: " in err
    assert "grew to" in result["detail"] and result["iterations"] < 30, result


def test_unscaled_rho_1_box_is_not_divergent(tmp_path):
    """The same box with its own F (rows sum to 1.0001): the fixed steps run to the end, no false alarm."""
    scene, ff = scene_with_ff(tmp_path, BOX.replace('reflectivity=".5,.5,.5"', 'reflectivity="1,1,1"'))
    p = radiosity("solve", scene, "--allow-reflectivity-ge-1", "--ff", ff, "--steps", "100", "--json", "--quiet")
    assert p.returncode == 0, p.stderr
    assert json.loads(p.stdout)["result"]["status"] == "steps_done"


# The lossless closed box (reflectivity 1, emission 1, walls facing in): every row of rho F sums to about 1, so
# (I - rho F) B = E has no solution. With a tolerance Jacobi (and Gauss-Seidel) stop as stagnant once the residual
# has not decreased for 100 steps: exit 3, "no solution", the record written with the status; not max_iter.
@pytest.mark.parametrize("args", [[], ["--precision", "double"], ["--method", "gauss-seidel"]])
def test_lossless_closed_box_has_no_solution(tmp_path, args):
    scene, ff = scene_with_ff(tmp_path, BOX.replace('reflectivity=".5,.5,.5"', 'reflectivity="1,1,1"'))
    result, err = failed_solve(tmp_path, scene, ff, "--tol", "1e-6", *args)
    assert result["status"] == "stagnant" and result["iterations"] < 200, result
    assert err.startswith("radiosity: numerical failure: no solution: "), err
    assert result["exit_status"] == 3 and result["exit_reason"].startswith("no solution: "), result


def test_max_iter_reached_exits_4_with_its_record(tmp_path):
    """--max-iter reached without the tolerance: exit 4, one line, the record says max_iter, nothing else written."""
    rec, out = tmp_path / "rec.jsonl", tmp_path / "out.xml"
    scene = ROOT / "radiosity" / "scenes" / "scene1.xml"
    ff = tmp_path / "s.ff"
    assert radiosity("formfactors", scene, "--hemicube", "16", "-o", ff, "--quiet").returncode == 0
    p = radiosity("solve", scene, "--ff", ff, "--tol", "1e-6", "--max-iter", "5", "--record", rec, "--output", out)
    assert p.returncode == 4, (p.returncode, p.stderr)
    assert p.stderr.startswith("radiosity: not converged: jacobi stopped at --max-iter 5") and \
        len(p.stderr.splitlines()) == 1, p.stderr
    assert "status max_iter after 5 iterations" in p.stdout and not out.exists()
    r = json.loads(rec.read_text())
    assert r["result"]["status"] == "max_iter" and r["result"]["exit_status"] == 4
    assert r["result"]["exit_reason"] in p.stderr


def test_disagreed_float64_check_exits_5_with_its_record(tmp_path):
    """A rule that stops far from the answer (the residual squared below 1e-6: the residual below 1e-3) converges by
    its own rule but its answer is about 1e-3 away, beyond the check's bound (1e-5 + 20 tol): exit 5, the record written;
    --no-verify keeps its meaning (no check, exit 0)."""
    rec = tmp_path / "rec.jsonl"
    scene = ROOT / "radiosity" / "scenes" / "scene1.xml"
    ff = tmp_path / "s.ff"
    assert radiosity("formfactors", scene, "--hemicube", "16", "-o", ff, "--quiet").returncode == 0
    args = ["solve", scene, "--ff", ff, "--tol", "1e-6", "--stop", "residual-e+squared", "--record", rec]
    p = radiosity(*args)
    assert p.returncode == 5, (p.returncode, p.stderr)
    assert p.stderr.startswith("radiosity: disagreed with its float64 check: max relative difference"), p.stderr
    assert "DISAGREED" in p.stdout
    r = json.loads(rec.read_text())
    assert r["result"]["status"] == "converged" and r["verify"]["agreed"] is False
    assert r["result"]["exit_status"] == 5 and r["result"]["exit_reason"] in p.stderr
    p = radiosity(*args, "--no-verify")
    assert p.returncode == 0, p.stderr
    assert json.loads(rec.read_text().splitlines()[1])["result"]["exit_status"] == 0


# Emission 1e39 is a finite number in the scene file but above float's largest (3.4e38): the float solvers
# see Inf at the first step. In double the same scene solves.
@pytest.mark.parametrize("args", [["--tol", "1e-6"], ["--method", "bicgstab"], ["--steps", "8", "--backend", "original"]])
def test_emission_beyond_float_is_nonfinite(tmp_path, args):
    scene, ff = scene_with_ff(tmp_path, BOX.replace('emission="1,1,1"', 'emission="1e39,1e39,1e39"'))
    result, _ = failed_solve(tmp_path, scene, ff, *args)
    assert result["status"] == "nonfinite" and result["iterations"] <= 1, result
    p = radiosity("solve", scene, "--ff", ff, "--precision", "double", "--json", "--quiet")
    assert p.returncode == 0 and json.loads(p.stdout)["result"]["status"] == "converged", p.stderr


def test_nan_form_factor_is_nonfinite(tmp_path):
    """A NaN in F with a correct checksum (a bad hemicube, not a damaged file) is the solver's to catch."""
    scene, ff = scene_with_ff(tmp_path, BOX, lambda v: [math.nan if k == 5 else x for k, x in enumerate(v)])
    result, _ = failed_solve(tmp_path, scene, ff, "--tol", "1e-6")
    assert result["status"] == "nonfinite" and "step 1" in result["detail"], result


# ρF = [[0, 2], [0, 0]] (F_01 = 1, a fraction the reader accepts, and ρ = 2), E = 0 and B0 = (1, 1) from the radiosity
# attribute: r0 = E - A B0 = (1, -1), α = 1/2, s = (-1/2, -1/2), t = A s = (1/2, -1/2): t·s = 0, BiCG-STAB's ω is 0
# (tests/unit/solve/test_guards).
def test_bicgstab_breakdown_exits_3(tmp_path):
    scene, ff = scene_with_ff(tmp_path, TWO.format(attrs='reflectivity="2,2,2" radiosity="1,1,1"'),
                              lambda v: [0.0, 1.0, 0.0, 0.0])
    result, _ = failed_solve(tmp_path, scene, ff, "--method", "bicgstab", "--precision", "double")
    assert result["status"] == "breakdown" and "omega = t.s/t.t ~ 0" in result["detail"], result


def test_snapshots_before_the_failure_are_kept(tmp_path):
    """Pictures of steps before the guard fired are real steps; the one after it is never made."""
    scene, ff = scene_with_ff(tmp_path, BOX.replace('reflectivity=".5,.5,.5"', 'reflectivity="1,1,1"'),
                              lambda v: [1.5 * x for x in v])
    failed_solve(tmp_path, scene, ff, "--steps", "100", "--snapshots", "1,2,90",
                 "--snapshot-prefix", tmp_path / "snap")
    assert sorted(f.name for f in tmp_path.glob("snap_*")) == ["snap_iter1.png", "snap_iter2.png"]


# Inputs the fuzzers turned up: refused with exit 2 and one line, nothing written.
@pytest.mark.parametrize("vertex,expect", [('x="7e45"', "more than 1048576 patches"),
                                           ('x="1e200"', "triangle out of range"),
                                           ('x="x&#10;1"', "is not a number")])
def test_fuzz_found_scenes_are_refused_in_one_line(tmp_path, vertex, expect):
    scene = tmp_path / "s.xml"
    scene.write_text(TWO.format(attrs="").replace('x="1"', vertex, 1))
    out = tmp_path / "s.ff"
    p = radiosity("formfactors", scene, "-o", out)
    assert p.returncode == 2 and expect in p.stderr, p.stderr
    assert len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert not out.exists() and not (tmp_path / "s.ff.tmp").exists()
