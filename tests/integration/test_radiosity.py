"""bin/radiosity end to end: physics of the closed box, RRV's rooms, solver agreement through the real program,
snapshots and outputs, and bad input refused with exit status 2 and nothing written."""
import json
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from conftest import BIN, HAVE_RRV, ROOT, RRV, RRV_ABSENT, run

SCENES = ROOT / "radiosity" / "scenes"
requires_rrv = pytest.mark.skipif(not HAVE_RRV, reason=RRV_ABSENT)


def radiosity(*args, timeout=600):
    return run([BIN / "radiosity", *args], timeout=timeout)


def record(p):
    assert p.returncode == 0, p.stderr
    return json.loads([l for l in p.stdout.splitlines() if l.startswith("{")][-1])


def read_output(path):
    """Patches of an RRV output file: (area, emission, reflectivity, radiosity) arrays."""
    tris = ET.parse(path).getroot().iter("triangle")
    rows = []
    for t in tris:
        v = np.array([[float(x.get(k)) for k in "xyz"] for x in t.iter("vertex")])
        area = 0.5 * np.linalg.norm(np.cross(v[1] - v[0], v[2] - v[0]))
        col = [np.array([float(c) for c in t.get(k, "0,0,0").split(",")]) for k in ("emission", "reflectivity", "radiosity")]
        rows.append((area, *col))
    a = np.array([r[0] for r in rows])
    e, rho, b = (np.array([r[i] for r in rows]) for i in (1, 2, 3))
    return a, e, rho, b


@pytest.fixture(scope="module")
def box(tmp_path_factory):
    d = tmp_path_factory.mktemp("box")
    ff = d / "box.ff"
    p = radiosity("formfactors", SCENES / "closed_box.xml", "--divide", "0.02", "-o", ff, "--hemicube", "128", "--json", "--quiet")
    return d, ff, record(p)


def test_closed_box_rows_sum_to_one(box):
    _, _, rec = box
    assert rec["result"]["min_row_sum"] > 0.995 and rec["result"]["max_row_sum"] < 1.005


def test_closed_box_solves_to_e_over_one_minus_rho_and_balances_energy(box):
    d, ff, _ = box
    out = d / "box_out.xml"
    rec = record(radiosity("solve", SCENES / "closed_box.xml", "--divide", "0.02", "--ff", ff, "--tol", "1e-8",
                           "--precision", "double", "--output", out, "--json", "--quiet"))
    assert rec["result"]["status"] == "converged"
    a, e, rho, b = read_output(out)
    assert np.allclose(b, 1.0 / (1 - 0.5), rtol=0.01)  # E / (1 - ρ) = 2; hemicube row sums are within 0.5% of 1
    absorbed = np.sum(a[:, None] * (b - e) * (1 - rho) / rho, axis=0)
    emitted = np.sum(a[:, None] * e, axis=0)
    assert np.allclose(absorbed, emitted, rtol=0.01)


@pytest.fixture(scope="module")
def scene1(tmp_path_factory):
    d = tmp_path_factory.mktemp("scene1")
    ff = d / "scene1.ff"
    record(radiosity("formfactors", SCENES / "scene1.xml", "-o", ff, "--hemicube", "64", "--json", "--quiet"))
    return d, ff


def solve_scene1(scene1, *args):
    d, ff = scene1
    out = d / "out.xml"
    rec = record(radiosity("solve", SCENES / "scene1.xml", "--ff", ff, "--output", out, "--json", "--quiet", *args))
    return rec, read_output(out)[3]


def test_jacobi_and_bicgstab_agree_within_tolerance(scene1):
    rj, bj = solve_scene1(scene1, "--method", "jacobi", "--tol", "1e-6")
    rb, bb = solve_scene1(scene1, "--method", "bicgstab", "--tol", "1e-6")
    assert rj["result"]["status"] == rb["result"]["status"] == "converged"
    assert rb["result"]["iterations"] < rj["result"]["iterations"]
    assert np.max(np.abs(bj - bb)) <= 2e-5 * np.max(np.abs(bj))


@pytest.mark.parametrize("method", ["jacobi", "bicgstab"])
def test_aos_and_soa_agree(scene1, method):
    _, a = solve_scene1(scene1, "--method", method, "--layout", "aos", "--tol", "1e-7")
    _, s = solve_scene1(scene1, "--method", method, "--layout", "soa", "--tol", "1e-7")
    assert np.max(np.abs(a - s)) <= 1e-6 * np.max(np.abs(a))


@pytest.mark.parametrize("backend,layout", [("serial", "aos"), ("serial", "soa"), ("openmp", "aos"), ("openmp", "soa"), ("original", "aos")])
def test_every_backend_agrees_with_the_float64_reference(scene1, backend, layout):
    rec, _ = solve_scene1(scene1, "--backend", backend, "--layout", layout, "--steps", "32")
    assert rec["result"]["status"] == "steps_done" and rec["result"]["iterations"] == 32
    assert rec["verify"]["agreed"] is True, rec["verify"]
    assert rec["params"]["backend"] == backend and rec["provenance"]["git_commit"]


def test_snapshots_and_png(scene1, tmp_path):
    d, ff = scene1
    prefix = tmp_path / "fig42"
    p = radiosity("solve", SCENES / "scene1.xml", "--ff", ff, "--steps", "32", "--snapshots", "1,2,4,8,32",
                  "--snapshot-prefix", prefix, "--png", tmp_path / "final.png", "--size", "160x120", "--quiet")
    assert p.returncode == 0, p.stderr
    for k in (1, 2, 4, 8, 32):
        assert (tmp_path / f"fig42_iter{k}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (tmp_path / "final.png").stat().st_size > 0


@requires_rrv
@pytest.mark.parametrize("scene,patches,extra", [("room3.xml", 9680, ["--allow-reflectivity-ge-1"]), ("room2.xml", 17128, [])])
def test_rrv_rooms_patch_counts(scene, patches, extra):
    rec = record(radiosity("info", RRV / scene, *extra, "--json", "--quiet"))
    assert rec["result"]["patches"] == patches


@pytest.mark.parametrize("scene,patches", [("scene1.xml", 1312), ("scene2.xml", 3360)])
def test_report_scenes_1_and_2_patch_counts(scene, patches):
    assert record(radiosity("info", SCENES / scene, "--json", "--quiet"))["result"]["patches"] == patches


@requires_rrv
def test_room3_refused_without_flag_names_the_flag():
    p = radiosity("info", RRV / "room3.xml")
    assert p.returncode == 2 and "--allow-reflectivity-ge-1" in p.stderr and len(p.stderr.strip().splitlines()) == 1


TRI = '<triangle><vertex x="0" y="0" z="0"/><vertex x="1" y="0" z="0"/><vertex x="0" y="1" z="0"/></triangle>'


def scene_xml(body, head=""):
    return f'<scene><head>{head}<objectdef name="o">{body}</objectdef></head><body><object name="o"/></body></scene>'


BAD_SCENES = {
    "malformed": "<scene><head>",
    "unknown_element": scene_xml(f"<triangleset>{TRI}</triangleset><teacup/>"),
    "unknown_primitive": scene_xml("<dodecahedron/>"),
    "missing_coordinate": scene_xml('<triangleset><triangle><vertex x="0" y="0"/><vertex x="1" y="0" z="0"/>'
                                    '<vertex x="0" y="1" z="0"/></triangle></triangleset>'),
    "nan_colour": scene_xml(f'<triangleset emission="nan,0,0">{TRI}</triangleset>'),
    "negative_colour": scene_xml(f'<triangleset reflectivity="-0.1,0,0">{TRI}</triangleset>'),
    "rho_ge_1": scene_xml(f'<triangleset reflectivity="1,0.5,0.5">{TRI}</triangleset>'),
    "degenerate": scene_xml('<triangleset><triangle><vertex x="0" y="0" z="0"/><vertex x="1" y="0" z="0"/>'
                            '<vertex x="2" y="0" z="0"/></triangle></triangleset>'),
}


@pytest.mark.parametrize("name", sorted(BAD_SCENES))
def test_bad_scene_exits_2_one_line_nothing_written(tmp_path, name):
    scene = tmp_path / f"{name}.xml"
    scene.write_text(BAD_SCENES[name])
    out = tmp_path / "out.ff"
    p = radiosity("formfactors", scene, "-o", out)
    assert p.returncode == 2, (p.returncode, p.stderr)
    assert len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert not out.exists() and not Path(str(out) + ".tmp").exists()


def test_degenerate_triangle_message_says_where(tmp_path):
    scene = tmp_path / "deg.xml"
    scene.write_text(BAD_SCENES["degenerate"].replace("<triangleset>", "\n\n<triangleset>"))
    p = radiosity("info", scene)
    assert p.returncode == 2 and "deg.xml:3" in p.stderr, p.stderr


def test_reflectivity_ge_1_accepted_with_flag(tmp_path):
    scene = tmp_path / "rho1.xml"
    scene.write_text(BAD_SCENES["rho_ge_1"])
    assert radiosity("info", scene, "--allow-reflectivity-ge-1").returncode == 0


def test_form_factor_file_of_another_mesh_is_refused(scene1, tmp_path):
    _, ff = scene1
    out = tmp_path / "o.xml"
    p = radiosity("solve", SCENES / "scene2.xml", "--ff", ff, "--output", out)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert not out.exists()


def test_truncated_form_factor_file_is_refused(scene1, tmp_path):
    _, ff = scene1
    cut = tmp_path / "cut.ff"
    cut.write_bytes(ff.read_bytes()[:-1000])
    p = radiosity("solve", SCENES / "scene1.xml", "--ff", cut)
    assert p.returncode == 2 and "truncated" in p.stderr.lower(), p.stderr


def test_missing_form_factor_file_and_bad_options(scene1, tmp_path):
    for args in (["solve", SCENES / "scene1.xml", "--ff", tmp_path / "none.ff"],
                 ["solve", SCENES / "scene1.xml", "--ff", scene1[1], "--method", "gauss"],
                 ["solve", SCENES / "scene1.xml", "--ff", scene1[1], "--tol", "nan"],
                 ["solve", SCENES / "scene1.xml", "--ff", scene1[1], "--backend", "original", "--method", "bicgstab", "--steps", "3"],
                 ["formfactors", SCENES / "scene1.xml", "-o", tmp_path / "x.ff", "--hemicube", "7"],
                 ["formfactors", tmp_path / "no_such_scene.xml", "-o", tmp_path / "x.ff"],
                 []):
        p = radiosity(*args)
        assert p.returncode == 2, (args, p.stderr)
        assert len(p.stderr.strip().splitlines()) == 1, (args, p.stderr)
