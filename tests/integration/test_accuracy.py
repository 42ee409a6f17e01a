"""Speed against accuracy through bin/radiosity: the storage of the form factors (CSR, 16-bit values, threshold),
grey scenes solved as one channel, the error every record carries against a converged float64 reference, and the
extremes (a closed box with rho near 1, row sums above 1, a run that will not fit in memory)."""
import json
import math
import xml.etree.ElementTree as ET

import pytest

from bench import ff_file
from conftest import BIN, ROOT, run

BOX = (ROOT / "radiosity" / "scenes" / "closed_box.xml").read_text()

# The inside of the unit cube, grey, lit from the floor only: the answer is grey but not uniform.
FACES = {  # name: (emission, reflectivity, triangles facing outwards: room_xml turns them inwards)
    "floor": ("1,1,1", ".6,.6,.6", [((0, 0, 0), (0, 1, 0), (1, 0, 0)), ((1, 0, 0), (0, 1, 0), (1, 1, 0))]),
    "ceiling": ("0,0,0", ".6,.6,.6", [((0, 0, 1), (1, 0, 1), (0, 1, 1)), ((1, 0, 1), (1, 1, 1), (0, 1, 1))]),
    "walls": ("0,0,0", ".8,.8,.8", [((0, 0, 0), (1, 0, 0), (0, 0, 1)), ((1, 0, 0), (1, 0, 1), (0, 0, 1)),
                                    ((0, 1, 0), (0, 1, 1), (1, 1, 0)), ((1, 1, 0), (0, 1, 1), (1, 1, 1)),
                                    ((0, 0, 0), (0, 0, 1), (0, 1, 0)), ((0, 1, 0), (0, 0, 1), (0, 1, 1)),
                                    ((1, 0, 0), (1, 1, 0), (1, 0, 1)), ((1, 1, 0), (1, 1, 1), (1, 0, 1))]),
}


def room_xml(colour_walls=False):
    sets = []
    for name, (e, rho, tris) in FACES.items():
        if colour_walls and name == "walls":
            rho = ".8,.5,.3"
        body = "".join("<triangle>" + "".join(f'<vertex x="{x}" y="{y}" z="{z}"/>' for x, y, z in t[::-1]) +
                       "</triangle>" for t in tris)
        sets.append(f'<triangleset name="{name}" emission="{e}" reflectivity="{rho}">{body}</triangleset>')
    return ('<scene><head><objectdef name="room">' + "".join(sets) +
            '</objectdef></head><body><object name="room"/></body></scene>')


def radiosity(*args):
    return run([BIN / "radiosity", *args], timeout=300)


def scene_with_ff(tmp_path, xml, edit=None, divide="0.05", hemicube="32"):
    """The scene written to tmp_path, its form factors (edited by edit(values) -> values if given), and the
    formfactors record."""
    scene = tmp_path / "scene.xml"
    scene.write_text(xml)
    ff = tmp_path / "scene.ff"
    p = radiosity("formfactors", scene, "--allow-reflectivity-ge-1", "--divide", divide, "--hemicube", hemicube, "-o",
                  ff, "--quiet", "--json")
    assert p.returncode == 0, p.stderr
    if edit:
        header, values = ff_file.read(ff)
        ff_file.rewrite(ff, header, edit(values))
    return scene, ff, json.loads(p.stdout)


def solve(tmp_path, scene, ff, *args, divide="0.05", name="out"):
    """A solve that must succeed: its record and its radiosity per patch (from --output)."""
    out = tmp_path / f"{name}.xml"
    p = radiosity("solve", scene, "--allow-reflectivity-ge-1", "--divide", divide, "--ff", ff, "--output", out,
                  "--json", "--quiet", *args)
    assert p.returncode == 0, p.stderr
    B = [[float(x) for x in t.get("radiosity").split(",")] for t in ET.parse(out).iter("triangle")]
    return json.loads(p.stdout), B


def max_rel_diff(B, R):
    return max(abs(b - r) for x, y in zip(B, R) for b, r in zip(x, y)) / max(abs(r) for y in R for r in y)


def test_grey_scene_solves_one_channel_with_the_answer_of_three(tmp_path):
    scene, ff, _ = scene_with_ff(tmp_path, room_xml())
    for method in ("jacobi", "bicgstab"):
        one, B1 = solve(tmp_path, scene, ff, "--method", method, "--tol", "1e-7", name="one")
        three, B3 = solve(tmp_path, scene, ff, "--method", method, "--tol", "1e-7", "--channels", "3", name="three")
        assert one["result"]["channels"] == 1 and three["result"]["channels"] == 3
        assert one["params"]["channels"] == "auto" and three["params"]["channels"] == "3"
        assert one["verify"]["agreed"] is True and three["verify"]["agreed"] is True
        assert max_rel_diff(B1, B3) <= 1e-6
        assert all(b[0] == b[1] == b[2] for b in B1)


def test_coloured_scene_solves_three_channels(tmp_path):
    scene, ff, _ = scene_with_ff(tmp_path, room_xml(colour_walls=True))
    rec, _ = solve(tmp_path, scene, ff, "--tol", "1e-6")
    assert rec["result"]["channels"] == 3


@pytest.mark.parametrize("args", [[], ["--precision", "double"], ["--method", "bicgstab"], ["--steps", "20"]])
def test_csr_and_dense_agree_at_threshold_zero(tmp_path, args):
    scene, ff, _ = scene_with_ff(tmp_path, room_xml(colour_walls=True))
    dense, Bd = solve(tmp_path, scene, ff, "--storage", "dense", *args, name="dense")
    csr, Bc = solve(tmp_path, scene, ff, "--storage", "csr", *args, name="csr")
    assert csr["params"]["storage"] == "csr" and dense["params"]["storage"] == "dense"
    assert max_rel_diff(Bc, Bd) <= 1e-6
    n = dense["params"]["patches"]
    assert csr["result"]["kept"] == dense["result"]["kept"] < n * n  # faces do not see themselves
    assert csr["result"]["matrix_storage_bytes"] == 8 * csr["result"]["kept"] + 8 * (n + 1)
    assert dense["result"]["matrix_storage_bytes"] == 4 * n * n


def test_storage_threshold_and_16_bits_cost_error_and_save_memory(tmp_path):
    scene, ff, _ = scene_with_ff(tmp_path, room_xml(colour_walls=True))
    base, _ = solve(tmp_path, scene, ff, "--tol", "1e-8", "--precision", "double", "--storage", "dense")
    assert base["result"]["error_vs_reference"] <= 1e-7
    assert base["result"]["reference"]["converged"] is True
    auto, _ = solve(tmp_path, scene, ff, "--tol", "1e-8", "--precision", "double", "--storage", "auto",
                    "--threshold", "1e-3")
    assert auto["params"]["storage_requested"] == "auto"
    n2 = base["params"]["patches"] ** 2
    kept, n = auto["result"]["kept"], base["params"]["patches"]
    # the fewest bytes: runs or compressed where they move well under dense's (kSparseShare, storage_choice.hpp: half;
    # 0.4 leaves room for rows dense skips), else dense
    if 6 * kept + 8 * (n + 1) < 0.4 * 4 * n2:
        assert auto["params"]["storage"] in ("compressed", "runs")
    if auto["params"]["storage"] != "dense":
        assert auto["result"]["matrix_storage_bytes"] <= min(6 * kept + 8 * (n + 1), 4 * n2)
    assert auto["result"]["kept"] < base["result"]["kept"]
    assert auto["result"]["error_vs_reference"] > base["result"]["error_vs_reference"]
    half, _ = solve(tmp_path, scene, ff, "--tol", "1e-8", "--precision", "double", "--ff-precision", "float16",
                    "--storage", "dense")
    assert half["result"]["matrix_storage_bytes"] == 2 * n2
    assert 1e-6 < half["result"]["error_vs_reference"] < 1e-2
    assert half["verify"]["agreed"] is True  # checked on the matrix it solved: its own rounding is no disagreement


def test_closed_box_rho_099_reaches_e_over_one_minus_rho(tmp_path):
    """E/(1 - rho) needs rows that sum to 1; the hemicube's sum to s = 1 within about 1e-5 at R = 256 (5e-4 at
    R = 32), and 1/(1 - rho) = 100 amplifies that, so the answer of the F we have is E/(1 - rho s): within the
    tolerance asked (times the condition number bound 2/(1 - rho)) of that, for every patch. (The unit test
    Extremes.ClosedBox... checks E/(1 - rho) itself on rows that sum to exactly 1.)"""
    scene, ff, ffrec = scene_with_ff(tmp_path, BOX.replace('reflectivity=".5,.5,.5"', 'reflectivity=".99,.99,.99"'),
                                     divide="0.1", hemicube="256")
    sums = ffrec["result"]
    tol, rho = 1e-6, 0.99
    rec, B = solve(tmp_path, scene, ff, "--tol", str(tol), "--precision", "double", "--max-iter", "5000", divide="0.1")
    assert rec["result"]["status"] == "converged"
    assert abs(rec["result"]["iterations"] - math.log(tol) / math.log(rho)) < 20
    slack = tol * 2 / (1 - rho)
    low, high = 1 / (1 - rho * sums["min_row_sum"]), 1 / (1 - rho * sums["max_row_sum"])
    assert all(low * (1 - slack) <= b <= high * (1 + slack) for x in B for b in x), (low, high, B[0])
    assert abs(B[0][0] - 100) < 0.5
    assert rec["result"]["error_vs_reference"] <= slack


@pytest.mark.parametrize("storage", ["dense", "csr"])
def test_row_sums_above_one_with_rho_1_are_divergent_exit_3(tmp_path, storage):
    scene, ff, _ = scene_with_ff(tmp_path, BOX.replace('reflectivity=".5,.5,.5"', 'reflectivity="1,1,1"'),
                                 edit=lambda v: [1.5 * x for x in v], divide="1")
    rec = tmp_path / "rec.jsonl"
    p = radiosity("solve", scene, "--allow-reflectivity-ge-1", "--divide", "1", "--ff", ff, "--tol", "1e-6",
                  "--storage", storage, "--record", rec)
    assert p.returncode == 3, (p.stdout, p.stderr)
    assert len(p.stderr.strip().splitlines()) == 1
    assert p.stderr.startswith("radiosity: numerical failure: divergent: jacobi: the residual in channel r grew to")
    r = json.loads(rec.read_text())
    assert r["result"]["status"] == "divergent" and r["result"]["iterations"] < 30
    assert r["result"]["error_vs_reference"] is None


def test_a_run_that_will_not_fit_is_refused_before_it_allocates(tmp_path):
    """786432 patches: the form-factor file alone would be 2304 GiB. Refused from the patch count, before the file
    (which need not exist) is opened."""
    scene = tmp_path / "box.xml"
    scene.write_text(BOX)
    p = radiosity("solve", scene, "--divide", "1e-5", "--ff", tmp_path / "none.ff", "--storage", "csr")
    assert p.returncode == 2
    assert len(p.stderr.strip().splitlines()) == 1
    assert "a solve of 786432 patches (the form-factor file's dense float32 values 2304.000 GiB" in p.stderr
    assert "GiB of memory, and this machine has" in p.stderr


@pytest.mark.parametrize("args", [["--storage", "csr"], ["--ff-precision", "bfloat16"]])
def test_backends_that_read_dense_float32_refuse_other_storage(tmp_path, args):
    scene, ff, _ = scene_with_ff(tmp_path, BOX, divide="1")
    p = radiosity("solve", scene, "--divide", "1", "--ff", ff, "--steps", "4", "--backend", "original", *args)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1
    assert "backend 'original' does not read" in p.stderr and "form factors (serial, openmp" in p.stderr
