"""Reproducing on any machine (issue 14): each machine's own records under results/<machine>/, the reference machine's
tables regenerated from its committed records, RRV's scenes fetched and checked, a main command that ends well
where the scenes are missing."""
import filecmp
import hashlib
import json
import re
import shutil
import sys

import pytest

from conftest import BIN, ROOT, run

sys.path.insert(0, str(ROOT / "common"))
import machine_label  # noqa: E402

SHARED = ROOT.parent / "shared" / "scenes"
REFERENCE = (ROOT / "results" / "REFERENCE").read_text().strip()
EXPS = ["formfactors", "table41", "table42"]


def env(tmp_path, machine, **kw):
    return {"RESULTS": str(tmp_path / "results"), "FF_DIR": str(tmp_path / "ff"), "PRESET": "ci", "REPEAT": "1",
            "MACHINE": machine, "ANALYSIS_ALL_RECORDS": "1", **kw}  # records of this tree, clean or not


def ran(out):
    """The (case, repeat) lines the runner ran, not those it found recorded."""
    return [l for l in out.splitlines() if l.startswith("run-case: ") and " repeat " in l and ": bin/" in l]


def test_label_is_made_of_host_cpu_cores_gpu_and_is_checked():
    assert machine_label.make("vm", "AMD EPYC", 2) == "vm-amd-epyc-2c"
    assert machine_label.make("node7.cluster", "Intel(R) Xeon(R) CPU E5-2650 v2 @ 2.60GHz", 16, "NVIDIA H200") == \
        "node7-intel-xeon-e5-2650-v2-16c-nvidia-h200"
    for bad in ("", "paper", "tables", "../x", "a b", ".hidden", "x" * 81):
        with pytest.raises(ValueError):
            machine_label.check(bad)
    # the label the reference's own records derive is the folder they live in
    rec = json.loads((ROOT / "results" / REFERENCE / "table41" / "quick.jsonl").read_text().splitlines()[0])
    assert machine_label.from_record(rec) == REFERENCE
    # this machine's label is stable from one call to the next
    a = run([sys.executable, ROOT / "common" / "machine_label.py"], env={"MACHINE": ""})
    b = run([sys.executable, ROOT / "common" / "machine_label.py"], env={"MACHINE": ""})
    assert a.returncode == 0 and a.stdout == b.stdout and machine_label.check(a.stdout.strip())
    p = run([sys.executable, ROOT / "common" / "machine_label.py"], env={"MACHINE": "paper"})
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1


def test_two_machines_in_one_clone_keep_their_own_records(tmp_path):
    a = run([ROOT / "slurm" / "run-local", *EXPS], env=env(tmp_path, "a"), timeout=600)
    assert a.returncode == 0, a.stdout + a.stderr
    b = run([ROOT / "slurm" / "run-local", *EXPS], env=env(tmp_path, "b"), timeout=600)
    assert b.returncode == 0, b.stdout + b.stderr
    # b ran every case a ran: a's records never count as b's
    assert "repeat 0 already recorded" not in b.stdout and "0 already recorded on this machine" in b.stdout
    strip = lambda lines: sorted(l.split(": ", 2)[1] for l in lines)  # noqa: E731  (case and repeat)
    assert strip(ran(b.stdout)) == strip(ran(a.stdout)) and len(ran(a.stdout)) > 0
    for m in ("a", "b"):
        recs = [json.loads(l) for l in (tmp_path / "results" / m / "table41" / "ci.jsonl").read_text().splitlines()]
        assert recs and all(r["provenance"]["env"]["HPCGI_MACHINE"] == m for r in recs)
        assert json.loads((tmp_path / "results" / m / "machine.json").read_text())["label"] == m
    # make report for a; then make resume for b runs nothing; a's report is not changed by b's runs
    e = env(tmp_path, "a")
    assert run(["make", "-s", "report", "PRESET=ci", "MACHINE=a"], env=e, cwd=ROOT, timeout=300).returncode == 0
    report_a = tmp_path / "results" / "report" / "a" / "REPORT-ci.md"
    before = report_a.read_text()
    table_a = (tmp_path / "results" / "a" / "tables" / "table41_ci.md").read_text()
    p = run(["make", "-s", "resume", "PRESET=ci", "MACHINE=b", f"EXPERIMENTS={' '.join(EXPS)}"],
            env=env(tmp_path, "b"), cwd=ROOT, timeout=600)
    assert p.returncode == 0, p.stdout + p.stderr
    assert ran(p.stdout) == [] or all(any(g in l for g in ("cublas", "cuda")) for l in ran(p.stdout)), ran(p.stdout)
    assert "0 cases run" in p.stdout
    n_b = len((tmp_path / "results" / "b" / "table41" / "ci.jsonl").read_text().splitlines())
    extra = run([ROOT / "slurm" / "run-case", "table41", "0"], env=env(tmp_path, "b", REPEAT="3"))
    assert extra.returncode == 0 and len((tmp_path / "results" / "b" / "table41" / "ci.jsonl").read_text().splitlines()) == n_b + 2
    assert run(["make", "-s", "report", "PRESET=ci", "MACHINE=a"], env=e, cwd=ROOT, timeout=300).returncode == 0
    assert report_a.read_text() == before
    assert (tmp_path / "results" / "a" / "tables" / "table41_ci.md").read_text() == table_a
    # make report never writes the machines page (issue 48: it is committed); make machines does, listing both, each
    # with its own numbers
    assert not (tmp_path / "results" / "report" / "MACHINES.md").exists()
    assert run(["make", "-s", "machines", "PRESET=ci"], env=e, cwd=ROOT, timeout=300).returncode == 0
    page = (tmp_path / "results" / "report" / "MACHINES.md").read_text()
    assert "| a " in page and "| b " in page
    # with b as the reference, a's report says what differs between them: the same CPU and cores, each its own probes
    (tmp_path / "results" / "REFERENCE").write_text("b\n")
    assert run(["make", "-s", "report", "PRESET=ci", "MACHINE=a"], env=e, cwd=ROOT, timeout=300).returncode == 0
    line = next(l for l in report_a.read_text().splitlines() if "What differs between this machine and the reference b" in l)
    same = re.search(r"\(the same: ([^)]*)\)", line)
    assert same and {"CPU", "cores", "GPU"} <= set(same[1].split(", ")), line
    assert re.search(r"GB/s \(median of \d+\)", line) or "bandwidth probe" in same[1], line


def test_reference_tables_regenerate_from_its_committed_records(tmp_path):
    """make plots MACHINE=<reference> gives today's tables of every preset it has committed tables of (quick, and
    paper's Table 4.2 and its audit): the same numbers, from the records alone."""
    res = tmp_path / "results"
    shutil.copytree(ROOT / "results" / REFERENCE, res / REFERENCE,
                    ignore=shutil.ignore_patterns("tables", "plots"))
    shutil.copy(ROOT / "results" / "REFERENCE", res / "REFERENCE")
    committed = ROOT / "results" / REFERENCE / "tables"
    names = sorted(f.name for f in committed.iterdir() if not f.name.startswith("bench_"))  # bench: make bench's
    assert "table41_quick.md" in names and "table42_quick.csv" in names
    presets = sorted({n.rsplit(".", 1)[0].rsplit("_", 1)[1] for n in names})
    assert "quick" in presets
    for preset in presets:
        p = run([sys.executable, "-m", "analysis", "tables", preset, "--machine", REFERENCE], env={"RESULTS": str(res)},
                cwd=ROOT, timeout=600)
        assert p.returncode == 0, p.stderr
    for name in names:
        assert filecmp.cmp(committed / name, res / REFERENCE / "tables" / name, shallow=False), name


def standin_repo(tmp_path, tamper=False):
    """A local git repository laid out like RRV's (scene/room2.xml, scene/room3.xml, src/TeapotEntityDef.cpp), made
    from the copies in ../shared; with tamper=True room3.xml has one byte more. Returns (file URL, commit)."""
    repo = tmp_path / ("tampered" if tamper else "rrv")
    (repo / "scene").mkdir(parents=True)
    (repo / "src").mkdir()
    for f in ("room2.xml", "room3.xml"):
        shutil.copy(SHARED / "rrv" / f, repo / "scene" / f)
    shutil.copy(SHARED / "rrv-src" / "TeapotEntityDef.cpp", repo / "src")
    shutil.copy(SHARED / "rrv" / "COPYING", repo / "COPYING")
    if tamper:
        with open(repo / "scene" / "room3.xml", "a") as f:
            f.write(" ")
    g = {"GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@t", "GIT_COMMITTER_NAME": "t", "GIT_COMMITTER_EMAIL": "t@t"}
    for cmd in (["git", "init", "-q"], ["git", "add", "."], ["git", "commit", "-qm", "stand-in"]):
        assert run(cmd, env=g, cwd=repo).returncode == 0
    commit = run(["git", "rev-parse", "HEAD"], cwd=repo).stdout.strip()
    return f"file://{repo}", commit


needs_shared = pytest.mark.skipif(not (SHARED / "rrv-src" / "TeapotEntityDef.cpp").exists(),
                                  reason=f"RRV's files to build a stand-in repository are not in {SHARED}")


def info(scene, **e):
    p = run([BIN / "radiosity", "info", scene, "--allow-reflectivity-ge-1", "--json", "--quiet"], env=e)
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout)["result"]


@needs_shared
def test_make_scenes_fetches_checks_and_refuses_a_tampered_file(tmp_path):
    url, commit = standin_repo(tmp_path)
    cache = tmp_path / "cache"
    e = {"RRV_URL": url, "RRV_COMMIT": commit, "SCENES_CACHE": str(cache), "RRV_SCENES": ""}
    p = run(["make", "-s", "scenes"], env=e, cwd=ROOT, timeout=120)
    assert p.returncode == 0, p.stdout + p.stderr
    for f in ("room2.xml", "room3.xml", "teapot.obj", "COPYING"):
        assert (cache / f).is_file(), f
    assert hashlib.sha256((cache / "room3.xml").read_bytes()).hexdigest() == \
        "c8a1de00685401146e45c5f10795e3523cf9f4f4600ad535f5babb7724ebf56a"
    # the scenes are found in the cache first (no RRV_SCENES), and give RRV's meshes: same patches, same hash
    found = run([ROOT / "radiosity" / "scenes" / "rrv" / "dir"], env={"SCENES_CACHE": str(cache), "RRV_SCENES": ""})
    assert found.returncode == 0 and found.stdout.strip() == str(cache)
    for scene, patches in (("room3.xml", 9680), ("room2.xml", 17128)):
        mine, theirs = info(cache / scene), info(SHARED / "rrv" / scene)
        assert mine["patches"] == patches and mine["mesh_hash"] == theirs["mesh_hash"], scene
    # a tampered input: refused with one line, exit non-zero, nothing left behind in a fresh cache
    url2, commit2 = standin_repo(tmp_path, tamper=True)
    cache2 = tmp_path / "cache2"
    p = run(["make", "-s", "scenes"], env={**e, "RRV_URL": url2, "RRV_COMMIT": commit2, "SCENES_CACHE": str(cache2)},
            cwd=ROOT, timeout=120)
    assert p.returncode != 0
    errors = [l for l in p.stderr.splitlines() if l.startswith("scenes:")]
    assert len(errors) == 1 and "refused scene/room3.xml" in errors[0] and "SHA-256" in errors[0], p.stderr
    assert not cache2.exists() or list(cache2.iterdir()) == []


def test_teapot_converter_refuses_a_truncated_source(tmp_path):
    src = tmp_path / "TeapotEntityDef.cpp"
    src.write_text("const Vertex TeapotEntity::teapot_v[1976] = {\n    Vertex(1,2,3)\n};\n")
    out = tmp_path / "teapot.obj"
    p = run([sys.executable, ROOT / "radiosity" / "scenes" / "rrv" / "teapot_obj.py", src, out])
    assert p.returncode == 1 and len(p.stderr.strip().splitlines()) == 1 and not out.exists()
    assert list(tmp_path.iterdir()) == [src]


def test_reproduce_without_rrv_scenes_ends_well_and_names_what_it_skipped(tmp_path):
    empty = tmp_path / "no-scenes"
    empty.mkdir()
    e = env(tmp_path, "no-rrv", RRV_SCENES=str(empty), SCENES_CACHE=str(tmp_path / "no-cache"))
    p = run(["make", "-s", "reproduce", "PRESET=ci", "EXPERIMENTS=formfactors table42 figure42"], env=e, cwd=ROOT,
            timeout=900)
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    tail = p.stdout[p.stdout.rindex("run-local: summary"):]
    assert "skipped, no RRV scenes (2): formfactors/1 figure42/0" in tail and "0 failed" in tail and "make scenes" in tail
    report = (tmp_path / "results" / "report" / "no-rrv" / "REPORT-ci.md").read_text()
    # the report's table of experiments says what did not run and why
    assert "| figure42 | did not run | 0 | 0 | 0 | 1 skipped: no RRV scenes |" in report, report
    assert "| formfactors | ran | 1 | 1 | 0 | 1 skipped: no RRV scenes |" in report
