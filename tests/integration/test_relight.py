"""bin/radiosity relight and web end to end (issue 20): light mixes served from the basis against cold float64 solves,
the basis file tied to its inputs, warm-started reflectivity frames against cold ones, bad frames refused with exit
status 2 and nothing written, and the page in headless Chromium (file URL, no console message, no request of the
page's own, screenshots that differ with the lights, the hidden radiosity equal to relight's frame)."""
import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from conftest import BIN, ROOT, run

SCENE2 = ROOT / "radiosity" / "scenes" / "scene2.xml"


def radiosity(*args, timeout=900):
    return run([BIN / "radiosity", *map(str, args)], timeout=timeout)


def record(p):
    assert p.returncode == 0, p.stderr
    return json.loads([l for l in p.stdout.splitlines() if l.startswith("{")][-1])


@pytest.fixture(scope="module")
def scene2(tmp_path_factory):
    d = tmp_path_factory.mktemp("relight")
    ff = d / "scene2.ff"
    record(radiosity("formfactors", SCENE2, "-o", ff, "--hemicube", "32", "--json", "--quiet"))
    basis = d / "scene2.basis"
    return d, ff, basis


def relight(ff, *args):
    return radiosity("relight", SCENE2, "--ff", ff, "--threads", "2", "--json", "--quiet", *args)


def test_info_lists_lights_and_entities_by_instance():
    rec = record(radiosity("info", SCENE2, "--json"))
    named = {e["name"]: e for e in rec["result"]["named"]}
    assert [n for n, e in named.items() if e["light"]] == ["light.1", "light.2"]
    assert named["light.1"]["emission"] == [6, 6, 5.5] and named["room.1"]["patches"] > 1000
    assert not named["room.1"]["uniform_reflectivity"]  # its walls differ: reported, not hidden
    p = radiosity("info", SCENE2)
    assert re.search(r"light\s+light\.2\s+24 patches", p.stdout), p.stdout


def test_twenty_random_mixes_agree_with_cold_float64_solves(scene2):
    d, ff, basis = scene2
    rec = record(relight(ff, "--random-frames", 20, "--seed", 3, "--check-every", 1, "--basis", basis))
    res = rec["result"]
    assert res["basis"]["max_residual"] <= 1e-7 and not res["basis"]["loaded"]
    assert res["checked_frames"] == 20 and all(f["kind"] == "basis" for f in res["per_frame"])
    assert res["worst_error"] <= 1e-5, res["worst_error"]
    assert basis.exists()


def test_basis_file_is_read_back_and_gives_the_same_frames(scene2):
    d, ff, basis = scene2
    if not basis.exists():
        record(relight(ff, "--random-frames", 1, "--basis", basis))
    args = ("--random-frames", 5, "--seed", 9, "--record-patches", 4)
    fresh = record(relight(ff, *args))["result"]
    read = record(relight(ff, *args, "--basis", basis))["result"]
    assert read["basis"]["loaded"] and not fresh["basis"]["loaded"]
    a = np.array([f["radiosity"] for f in fresh["per_frame"]])
    b = np.array([f["radiosity"] for f in read["per_frame"]])
    assert a.shape == (5, 4, 3) and np.array_equal(a, b)
    assert len({tuple(x.ravel()) for x in a}) == 5  # five different mixes


def test_basis_of_other_form_factors_is_refused(scene2):
    d, ff, basis = scene2
    if not basis.exists():
        record(relight(ff, "--random-frames", 1, "--basis", basis))
    other = d / "scene2-R16.ff"
    record(radiosity("formfactors", SCENE2, "-o", other, "--hemicube", "16", "--json", "--quiet"))
    p = relight(other, "--random-frames", 1, "--basis", basis)
    assert p.returncode == 2 and "other form factors" in p.stderr, p.stderr
    assert len(p.stderr.strip().splitlines()) == 1


def test_reflectivity_frames_warm_start_beats_cold_and_agree(scene2):
    d, ff, basis = scene2
    frames = d / "wall.json"
    frames.write_text(json.dumps({"frames": [
        {"reflectivity": {"room.1": [0.6, 0.6, 0.6]}},
        {"reflectivity": {"room.1": [0.54, 0.54, 0.54]}},
        {"lights": {"light.2": {"intensity": 0.3, "rgb": [1, 0.5, 0.2]}}}]}))
    rec = record(relight(ff, "--frames", frames, "--tol", "1e-6", "--check-every", 1, "--precision", "double"))
    fr = rec["result"]["per_frame"]
    assert [f["kind"] for f in fr] == ["solved", "solved", "solved"]  # room.1 stays changed: no basis frame
    for f in fr:
        assert f["status"] == "converged" and f["residual"] <= 1e-6
        assert f["error"] < 1e-4, f  # to 1e-6 against the float64 solution: tol times the condition number at most
    # a 10% change from the previous frame re-converges in fewer iterations than from RRV's cold start
    assert fr[1]["iterations"] < fr[1]["cold_iterations"], fr[1]
    assert rec["result"]["latency"]["p50_ms"] > 0 and rec["result"]["fps"] > 0


def test_frame_budget_stops_and_reports_the_residual(scene2):
    d, ff, basis = scene2
    frames = d / "budget.json"
    frames.write_text(json.dumps({"frames": [{"reflectivity": {"room.1": [0.8, 0.8, 0.8]}}]}))
    rec = record(relight(ff, "--frames", frames, "--tol", "1e-8", "--frame-budget-ms", "0.001"))
    f = rec["result"]["per_frame"][0]
    assert f["status"] == "budget" and f["residual"] > 1e-8 and np.isfinite(f["residual"])


def test_frame_stopped_at_max_iter_exits_4_with_its_record(scene2):
    d, ff, basis = scene2
    frames = d / "maxiter.json"
    frames.write_text(json.dumps({"frames": [{"reflectivity": {"room.1": [0.8, 0.8, 0.8]}}, {}]}))
    rec_file = d / "maxiter.jsonl"
    rec_file.unlink(missing_ok=True)
    # 1e-8: a tolerance float reaches (a lower one is refused before anything runs), but not in 2 steps
    p = relight(ff, "--frames", frames, "--tol", "1e-8", "--max-iter", "2", "--record", rec_file)
    assert p.returncode == 4, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "not converged: frame 0: jacobi stopped at --max-iter 2" in lines[0], p.stderr
    rec = json.loads(rec_file.read_text().splitlines()[-1])
    res = rec["result"]
    assert res["exit_status"] == 4 and res["exit_reason"].startswith("frame 0: jacobi stopped at --max-iter 2")
    assert [f["status"] for f in res["per_frame"]] == ["max_iter", "max_iter"] and res["solved_over_tol"] == 2
    # the same frames to a tolerance they reach are an answer: exit 0, exit_status 0
    ok = record(relight(ff, "--frames", frames, "--tol", "1e-4"))["result"]
    assert ok["exit_status"] == 0 and ok["exit_reason"] is None


def radiosity_of(rec):
    return np.array([f["radiosity"] for f in rec["result"]["per_frame"]])


@pytest.fixture(scope="module")
def dark_light_scene(tmp_path_factory):
    """scene2 with light.1's reflectivity 0 (its rows left out of a sparse F unless a frame makes it reflective)."""
    d = tmp_path_factory.mktemp("relight-dark")
    xml = d / "scene2-dark.xml"
    text = SCENE2.read_text()
    assert text.count('reflectivity=".1,.1,.1"') == 1
    xml.write_text(text.replace('reflectivity=".1,.1,.1"', 'reflectivity="0,0,0"'))
    ff = d / "dark.ff"
    record(radiosity("formfactors", xml, "-o", ff, "--hemicube", "32", "--json", "--quiet"))
    return d, xml, ff


def test_storage_runs_agrees_with_dense_and_holds_rows_a_frame_makes_reflective(dark_light_scene):
    d, xml, ff = dark_light_scene
    frames = d / "frames.json"
    frames.write_text(json.dumps({"frames": [
        {"lights": {"light.2": {"intensity": 0.5, "rgb": [1, 0.8, 0.6]}}},  # from the basis
        {"reflectivity": {"room.1": [0.6, 0.6, 0.6]}},
        {"reflectivity": {"light.1": [0.5, 0.5, 0.5]}},  # rows of reflectivity 0 in the scene become needed
        {"reflectivity": {"light.1": [0, 0, 0], "room.1": [0.54, 0.54, 0.54]}}]}))
    recs = {}
    for st in ("dense", "runs", "csr", "auto"):
        recs[st] = record(radiosity("relight", xml, "--ff", ff, "--threads", "2", "--json", "--quiet", "--frames",
                                    frames, "--tol", "1e-7", "--precision", "double", "--storage", st,
                                    "--record-patches", 100000, "--check-every", 1))
        assert recs[st]["params"]["storage_requested"] == st
        if st != "auto":
            assert recs[st]["params"]["storage"] == st
        assert recs[st]["result"]["worst_error"] < 1e-5, (st, recs[st]["result"]["worst_error"])
    assert recs["auto"]["params"]["storage"] in ("dense", "csr", "compressed", "runs")
    dense = radiosity_of(recs["dense"])
    for st in ("runs", "csr"):
        got = radiosity_of(recs[st])
        assert got.shape == dense.shape and got.shape[0] == 4
        assert np.abs(got - dense).max() <= 1e-5 * np.abs(dense).max(), st
    # without light.1's rows frame 2 would differ from dense: the light's patches reflect there
    assert np.abs(dense[2] - dense[1]).max() > 1e-3


def test_bench_rhs_names_its_storage_and_bad_storage_exits_2(scene2):
    d, ff, basis = scene2
    for st in ("runs", "dense"):
        rec = record(relight(ff, "--bench-rhs", 3, "--passes", 1, "--storage", st, "--ff-precision", "float16"))
        assert rec["params"]["storage"] == st and rec["result"]["rhs"] == 3
    p = relight(ff, "--bench-rhs", 3, "--passes", 1, "--storage", "diagonal")
    assert p.returncode == 2 and "--storage" in p.stderr, p.stderr
    # a backend without a k-right-hand-side product for the light basis is refused before anything is read
    p = relight(ff, "--random-frames", 1, "--storage", "runs", "--backend", "original")
    assert p.returncode == 2 and "no k-right-hand-side product" in p.stderr, p.stderr


@pytest.mark.parametrize("text,reason", [
    ('{"frames": [{}, {"lights": {"lamp.7": {"intensity": 1}}}]}', "frame 1: unknown light 'lamp.7'"),
    ('{"frames": [{"lights": {"light.1": {"intensity": NaN}}}]}', "(frame 0)"),
    ('{"frames": [{}, {"lights": {"light.1": {"rgb": [1, 0.5, 1e999]}}}]}', "(frame 1)"),
    ('{"frames": [{"lights": {"light.1": {"intensity": 1}}}', "malformed JSON"),
    ('{"frames": [{"reflectivity": {"room.1": [1, 0.5, 0.5]}}]}', "frame 0: reflectivity of 'room.1' is >= 1"),
])
def test_bad_frames_exit_2_with_file_frame_and_reason_and_write_nothing(scene2, text, reason):
    d, ff, basis = scene2
    bad = d / "bad.json"
    bad.write_text(text)
    out = d / "out"
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir()
    p = radiosity("relight", SCENE2, "--ff", ff, "--frames", bad, "--record", out / "r.jsonl", "--png-frames",
                  out / "f", "--basis", out / "b.basis")
    assert p.returncode == 2, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and str(bad) in lines[0] and reason in lines[0], p.stderr
    assert list(out.iterdir()) == []


CHROMIUM = shutil.which("chromium")
requires_chromium = pytest.mark.skipif(CHROMIUM is None, reason="no chromium on PATH (make deps installs Debian's)")
# Chromium's own background traffic (updates, time, accounts) is not the page's: those requests have no origin
# ("not an origin" in the net log); a request of the page loaded from a file URL has the opaque origin "null".
QUIET = ["--headless", "--no-sandbox", "--disable-background-networking", "--disable-component-update",
         "--disable-sync", "--no-pings", "--no-first-run", "--disable-default-apps", "--enable-unsafe-swiftshader",
         "--use-angle=swiftshader", "--enable-logging=stderr", "--v=0", "--virtual-time-budget=4000"]


def chromium(url, *args, cwd):
    net = cwd / "net.json"
    p = subprocess.run([CHROMIUM, *QUIET, f"--log-net-log={net}", *args, url], capture_output=True, text=True,
                       timeout=180, cwd=cwd)
    console = [l for l in p.stderr.splitlines() if ":CONSOLE" in l]
    events = json.loads(net.read_text())["events"] if net.exists() else []
    page_requests = [e["params"].get("url", "?") for e in events
                     if "initiator" in e.get("params", {}) and e["params"]["initiator"] != "not an origin"]
    return p, console, page_requests


@requires_chromium
def test_request_check_sees_a_page_request(tmp_path):
    """The net-log check can fail: a page that loads an image over HTTP shows up in it."""
    page = tmp_path / "control.html"
    page.write_text('<html><body><img src="http://127.0.0.1:9/x.png"></body></html>')
    _, _, requests = chromium(page.as_uri(), "--dump-dom", cwd=tmp_path)
    assert any("127.0.0.1:9" in u for u in requests), requests


@requires_chromium
def test_web_page_relights_offline_like_relight(scene2):
    d, ff, basis = scene2
    page = d / "scene2.html"
    rec = record(radiosity("web", SCENE2, "--ff", ff, "-o", page, "--json", "--quiet"))
    assert rec["result"]["lights"] == ["light.1", "light.2"]
    html = page.read_text()
    assert "default-src 'none'" in html and not re.search(r"(src|href)\s*=\s*[\"']?(https?:)?//", html)
    shots, relit = [], []
    settings = ["light.1=1.5,1,0.2,0.1&light.2=0,1,1,1", "light.1=0,1,1,1&light.2=1.5,0.1,0.4,1"]
    for k, s in enumerate(settings):
        url = page.as_uri() + "?spin=0&" + s
        shot = d / f"shot{k}.png"
        p, console, requests = chromium(url, "--window-size=800,500", f"--screenshot={shot}", cwd=d)
        assert p.returncode == 0 and shot.exists(), p.stderr[-2000:]
        assert console == [] and requests == [], (console, requests)
        shots.append(shot)
        p, console, requests = chromium(url, "--dump-dom", cwd=d)
        assert console == [] and requests == [], (console, requests)
        m = re.search(r'<pre id="relit" hidden="">(.*?)</pre>', p.stdout, re.S)
        assert m, p.stdout[:2000]
        relit.append(np.array(json.loads(m.group(1))))
    from PIL import Image
    a, b = (np.asarray(Image.open(s).convert("RGB"), dtype=float)[:, :540] for s in shots)  # the canvas, not the panel
    assert np.abs(a - b).mean() > 5 and a.std() > 5, (np.abs(a - b).mean(), a.std())
    # left light on: the left half brighter than the right; and the other way round
    assert a[:, :270].mean() - a[:, 270:].mean() > b[:, :270].mean() - b[:, 270:].mean()
    frames = d / "web-frames.json"
    frames.write_text(json.dumps({"frames": [
        {"lights": {"light.1": {"intensity": 1.5, "rgb": [1, 0.2, 0.1]}, "light.2": {"intensity": 0, "rgb": [1, 1, 1]}}},
        {"lights": {"light.1": {"intensity": 0, "rgb": [1, 1, 1]}, "light.2": {"intensity": 1.5, "rgb": [0.1, 0.4, 1]}}}]}))
    res = record(relight(ff, "--frames", frames, "--record-patches", 16))["result"]
    for k in range(2):
        want = np.array(res["per_frame"][k]["radiosity"])
        assert relit[k].shape == want.shape == (16, 3)
        assert np.max(np.abs(relit[k] - want)) <= 1e-5 * np.max(np.abs(want)), (relit[k], want)


def test_png_frames_render_each_frame(scene2):
    d, ff, basis = scene2
    frames = d / "dim.json"
    frames.write_text(json.dumps({"frames": [{"lights": {"light.1": {"intensity": x, "rgb": [1, x, x]}}}
                                             for x in (1.0, 0.5, 0.0)]}))
    record(relight(ff, "--frames", frames, "--png-frames", d / "dim", "--size", "64x48"))
    pngs = [d / f"dim_{k:04d}.png" for k in range(3)]
    assert all(p.exists() for p in pngs)
    assert len({p.read_bytes() for p in pngs}) == 3
