"""The GPU kit (make gpu-kit, gpu-kit/run), checked where there is no GPU: the folder's size and libraries, the
dry-run plan against the case lists, a run from a copy in a clean environment (the CPU step, "no GPU", exit 3,
nothing written outside its output folder), a step that does not fit its budget, and every GPU command of the plan.
What comes back from the node (make gpu-import, the summary, the checks) is in test_gpu_kit_results.py."""
import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import tarfile
from pathlib import Path

import pytest

from conftest import HAVE_RRV, ROOT, RRV_ABSENT, run

KIT = ROOT / "build" / "gpu-kit"
CLEAN = {"PATH": "/usr/bin:/bin"}  # env -i PATH=/usr/bin:/bin
# What a kit binary may take from the node: glibc's parts, the GCC runtime, cuBLAS, cuSPARSE (and its nvJitLink)
# and the driver.
ALLOWED = re.compile(r"^(linux-vdso|ld-linux-x86-64|libc|libm|libdl|librt|libpthread|libstdc\+\+|libgcc_s|libgomp|"
                     r"libcublas|libcublasLt|libcusparse|libnvJitLink|libcuda)\.so")
GPU_CASE = re.compile(r"--backend (cublas1|cublas2|cuda|cublas|hybrid)(\s|$)")


def clean_run(args, cwd, timeout=600):
    return subprocess.run(["/usr/bin/env", "-i", *(f"{k}={v}" for k, v in CLEAN.items()), *map(str, args)],
                          cwd=cwd, capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope="module")
def kit():
    if shutil.which("nvcc") is None and not Path("/usr/local/cuda/bin/nvcc").exists():
        pytest.skip("no nvcc on this machine: make gpu-kit cannot build the kit")
    if not HAVE_RRV:  # make gpu-kit packs RRV's scenes for the GPU node and refuses without them
        pytest.skip(f"make gpu-kit cannot pack RRV's scenes: {RRV_ABSENT}")
    # DIRTY_KIT=1: the tests try the kit of whatever tree they run in (a clean clone in CI); nothing they make counts
    p = run(["make", "--no-print-directory", "gpu-kit", "DIRTY_KIT=1"], cwd=ROOT, timeout=3600)
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    return KIT


def gpu_absent_reason(kit):
    """None when the kit's cuda backend runs here, else why not (the kit's own binary: bin/ need not be built)."""
    p = subprocess.run([kit / "bin" / "poisson", "--backend", "cuda", "--n", "4", "--quiet"], capture_output=True,
                       text=True, env={"PATH": "/usr/bin:/bin", "LD_LIBRARY_PATH": cublas_dir()}, timeout=120)
    return p.stderr.strip() if p.returncode == 2 and "needs an NVIDIA GPU" in p.stderr else None


def tree(folder):
    """{relative path: (size, mtime, sha256)} of every file and link under folder."""
    out = {}
    for p in sorted(Path(folder).rglob("*")):
        if p.is_file() or p.is_symlink():
            out[str(p.relative_to(folder))] = (p.lstat().st_size, p.lstat().st_mtime_ns,
                                               hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else "")
    return out


def cublas_dir():
    for d in (os.environ.get("CUDA_HOME", "/usr/local/cuda") + "/lib64", "/usr/local/cuda/lib64"):
        if (Path(d) / "libcublas.so.13").exists():
            return d
    pytest.skip("no cuBLAS 13 on this machine")


def paper_gpu_cases():
    """(experiment, index, line) of every GPU case of the paper preset, read here from the lists themselves."""
    out = []
    for f in sorted((ROOT / "slurm" / "cases" / "paper").glob("*.txt")):
        lines = [l for l in f.read_text().splitlines() if l.strip() and not l.lstrip().startswith("#")]
        out += [(f.stem, k, l) for k, l in enumerate(lines) if GPU_CASE.search(l)]
    return out


def test_without_rrv_scenes_make_gpu_kit_refuses_with_one_line_before_building(tmp_path):
    if shutil.which("nvcc") is None and not Path("/usr/local/cuda/bin/nvcc").exists():
        pytest.skip("no nvcc on this machine: make gpu-kit refuses for want of nvcc first")
    p = run(["make", "--no-print-directory", "gpu-kit", f"RRV_SCENES={tmp_path}", f"KIT={tmp_path / 'kit'}",
             "DIRTY_KIT=1"], cwd=ROOT)
    assert p.returncode == 2
    assert p.stderr.splitlines()[-2] == (f"make gpu-kit: the kit carries RRV's scenes, and {tmp_path} lacks room2.xml, "
                                        "room3.xml or teapot.obj: run 'make scenes' or set RRV_SCENES=DIR")
    assert p.stdout == "" and not (tmp_path / "kit").exists()


def test_the_kit_is_at_most_60_mib_and_holds_what_the_node_needs(kit):
    total = sum(p.stat().st_size for p in kit.rglob("*") if p.is_file())
    assert total <= 60 * 2**20, f"{total / 2**20:.1f} MiB"
    for f in ("run", "bin/poisson", "bin/radiosity", "bin/stream", "bin/solve_tests", "radiosity/scenes/scene1.xml",
              "radiosity/scenes/scene2.xml", "scenes/rrv/room2.xml", "scenes/rrv/room3.xml", "scenes/rrv/teapot.obj",
              "scenes/rrv/COPYING", "common/machine_label.py", "analysis/records.py",
              "tests/integration/test_radiosity_gpu.py", "KIT-MANIFEST.json"):
        assert (kit / f).is_file(), f
    for f in (ROOT / "slurm" / "cases" / "paper").glob("*.txt"):  # copied, not retyped
        assert (kit / "cases" / "paper" / f.name).read_bytes() == f.read_bytes(), f.name


def test_every_library_resolves_inside_the_kit_or_is_an_allowed_one(kit):
    env = {"PATH": "/usr/bin:/bin", "LD_LIBRARY_PATH": cublas_dir()}  # as the kit sets it: cuBLAS from the node
    carried = set()
    for b in sorted((kit / "bin").iterdir()):
        out = subprocess.run(["ldd", str(b)], capture_output=True, text=True, env=env).stdout
        assert "not found" not in out, f"{b.name}:\n{out}"
        for line in out.splitlines():
            name = line.split()[0]
            where = line.split("=>")[1].split()[0] if "=>" in line else name
            if os.path.realpath(where).startswith(str(kit.resolve()) + "/"):
                carried.add(name)
            else:
                assert ALLOWED.match(os.path.basename(name)), f"{b.name}: {line.strip()} is outside the kit"
        assert "libcudart" not in out, f"{b.name}: CUDA's runtime must be linked statically"
        dyn = subprocess.run(["readelf", "-d", str(b)], capture_output=True, text=True).stdout
        assert "$ORIGIN/../lib" in dyn, f"{b.name} has no $ORIGIN run path"
    assert {"libpugixml.so.1", "libpng16.so.16"} <= carried, carried


def test_dry_run_orders_what_matters_first_and_fits_6_minutes_with_a_reserve(kit):
    """Issue 47: the probe first, then every cell of the report's GPU tables once and the claims' paired rounds, then
    the speed targets, then memcheck and the extras; the steps that fit, within 6 minutes less the slack and the
    reserve; every GPU case of the paper preset's lists among them, read from the lists."""
    p = clean_run([kit / "run", "--dry-run", "--json"], cwd=kit)
    assert p.returncode == 0, p.stderr
    plan = json.loads(p.stdout)
    assert [(c["experiment"], c["index"], c["line"]) for c in plan["gpu_cases"]] == paper_gpu_cases()
    # 35 of the report's tables, 4 of MG-PCG (Table 4.1's cuda column), 8 beyond the report's lines, listed as the
    # others are: table43-steps32 (4 scenes), gpu-float16 (1), table45-overlap (3)
    assert len(plan["gpu_cases"]) == 47
    beyond = [c["experiment"] for c in plan["gpu_cases"] if c["experiment"] not in ("table41", "table43", "table44",
                                                                                    "table45")]
    assert sorted(beyond) == ["gpu-float16"] + ["table43-steps32"] * 4 + ["table45-overlap"] * 3, beyond
    steps, names = plan["steps"], [s["name"] for s in plan["steps"]]
    for exp, k, line in paper_gpu_cases():
        assert f"{exp} case {k}: {line}" in names
    assert all(s["estimate_s"] > 0 for s in steps)
    order = [plan["phases"].index(s["phase"]) for s in steps]
    assert order == sorted(order), "the steps run phase after phase"
    assert steps[0]["phase"] == "probe" and "bin/stream --device gpu" in steps[0]["name"]
    first_optional = next(k for k, s in enumerate(steps) if s["optional"])
    assert all(s["optional"] for s in steps[first_optional:]), "the optional steps come last"
    fit = [s for s in steps if s["fit"] == "run"]
    assert fit == steps[:len(fit)], "what fits is a prefix of the plan"
    assert plan["budget_s"] == 360 and plan["slack"] >= 0.2
    assert sum(s["estimate_s"] for s in fit) + plan["reserve_s"] <= (1 - plan["slack"]) * 360
    fitting = {s["phase"] for s in fit}
    assert {"probe", "inputs", "tables", "claims", "targets", "memcheck"} <= fitting, fitting
    # round 1 of the report's tables is whole: every GPU cell but N = 8192's plain CG, and the OpenMP cells beside
    tables = [s["name"] for s in steps if s["phase"] == "tables"]
    assert all(s in [f["name"] for f in fit] for s in tables)
    assert any("--backend openmp --threads {CORES} --n 1024" in n for n in tables)  # {CORES}: the node's, at its run
    assert not any("--n 8192 --max-iter" in n for n in tables)
    # the claims' rounds 2-6, each group side by side, at least one group whole within the budget
    rounds = [s["name"] for s in fit if s["phase"] == "claims"]
    assert rounds and all(any(f"claims round {r} of 6: " in n for n in rounds) for r in range(2, 7)), rounds
    targets = [s["name"] for s in steps if s["phase"] == "targets"]
    assert len(targets) == 3 and "--backend cuda --n 8192 --max-iter" in targets[0], targets
    text = clean_run([kit / "run", "--dry-run"], cwd=kit)
    assert text.returncode == 0, text.stderr
    total = re.search(r"total of the steps that fit: (\d+) s of (\d+) s \(([\d.]+) min; the budget with its slack and "
                      r"reserve 360 s = 6.0 min", text.stdout)
    assert total and int(total.group(1)) == sum(s["estimate_s"] for s in fit), text.stdout[-500:]
    for s in steps:
        assert re.search(rf"^\s*{s['estimate_s']} s\s+{s['fit']}\s+{re.escape(s['phase'])}\s+\[{re.escape(s['group'])}\] "
                         rf"{re.escape(s['name'])}$", text.stdout, re.M), s
    # the GPU multigrid gets the CPU's checks: against serial's, --check-symmetry, memcheck at a small N
    mg = [n for n in names if "multigrid" in n]
    assert mg == ["Poisson multigrid on the GPU against serial's at N = 256",
                  "Poisson multigrid on the GPU against serial's at N = 1024"], mg
    assert "compute-sanitizer memcheck: poisson cuda --precond mg N=50" in names
    # Table 4.5's --overlap never at d = 0 or 1 (its lines end in --storage dense)
    assert not [n for n in names if n.startswith("table45-overlap") and re.search(r"--distribution (0|1)\.0 ", n)]


def test_bad_budget_is_refused_with_one_line(kit):
    p = clean_run([kit / "run", "--dry-run", "--budget", "12"], cwd=kit)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr


def test_a_copy_run_in_a_clean_environment_says_no_gpu_and_writes_only_its_output(kit, tmp_path):
    if gpu_absent_reason(kit) is None:
        pytest.skip("a GPU is present: this test checks the kit where there is none")
    copy = tmp_path / "kit"
    shutil.copytree(kit, copy, symlinks=True)
    work = tmp_path / "work"
    work.mkdir()
    before = tree(tmp_path)
    p = clean_run([copy / "run", "--out", tmp_path / "out"], cwd=work)
    assert p.returncode == 3, p.stdout + p.stderr
    assert len(p.stderr.strip().splitlines()) == 1 and "no GPU" in p.stderr, p.stderr
    assert "ok form factors of scene1.xml" in p.stdout, p.stdout
    ff = tmp_path / "out" / "ff" / "paper-scene1.ff"
    assert ff.stat().st_size > 1312 * 1312 * 4
    assert not list((tmp_path / "out" / "ff").glob("paper-scene2*")), "only the CPU step of scene 1 runs"
    after = {k: v for k, v in tree(tmp_path).items() if not k.startswith("out/")}
    assert after == before, "files were written outside the output folder"
    assert not list((tmp_path / "out" / "results").rglob("*.jsonl")), "a record without a GPU"
    assert "no GPU" in (tmp_path / "out" / "summary.md").read_text() or "driver:" in p.stdout
    assert list((tmp_path / "out").glob("gpu-kit-*.tar.gz")), "the archive is written without a GPU too"


def kit_modules():
    sys.path.insert(0, str(ROOT))
    from gpukit import driver, summary
    return driver, summary


def kit_driver(kit, out, monkeypatch, budget, sanitizer=False):
    """gpu-kit/run's driver in this process on the built kit, its GPU probe answered 'present'; the sanitizer's
    probe answered 'not usable' unless `sanitizer` (so that a test does not depend on whether this machine has
    compute-sanitizer installed)."""
    driver, _ = kit_modules()
    from gpukit import node, probe
    monkeypatch.setattr(node, "probe_gpu", lambda env, kit: (None, None))
    if not sanitizer:
        monkeypatch.setattr(probe, "sanitizer", lambda *args: (False, "not looked for by this test"))
    monkeypatch.setattr(driver, "KIT", kit)
    d = driver.Driver(driver.argparse.Namespace(out=str(out), budget=budget, dry_run=False, json=False))
    d.label = "test-fake-gpu-node"
    return driver, d


def test_a_step_that_does_not_fit_is_skipped_by_name_and_the_archive_still_made(kit, tmp_path, monkeypatch):
    """The GPU path of gpu-kit/run with the GPU probe answered 'present' and a budget that fits only scene 1."""
    driver, d = kit_driver(kit, tmp_path / "out", monkeypatch, 200.0)
    steps = d.plan()
    others = [s for s in steps if s.name != "form factors of scene1.xml"]
    for s in others:  # every step but scene 1's form factors estimated past the budget (this machine is slow)
        s.estimate_s = 10_000
    assert driver.run(d, steps) == 6  # skipped steps: not all ran, and nothing failed
    assert [n for n, _, _ in d.done] == ["form factors of scene1.xml"]
    assert sorted(d.skipped) == sorted(s.name for s in others) and not d.failed
    archive = tmp_path / "out" / "gpu-kit-test-fake-gpu-node.tar.gz"
    assert archive.stat().st_size <= 16 * 2**20
    with tarfile.open(archive) as t:
        names = t.getnames()
    assert {"summary.md", "logs/progress.log", "results/test-fake-gpu-node/machine.json"} <= set(names), names
    text = (tmp_path / "out" / "summary.md").read_text()
    assert f"- skipped (time, a library or a tool the node lacks): {len(steps) - 1}" in text
    # the plan's estimate beside each step
    assert "| 1 | form factors of scene1.xml | formfactors | 1 | " in text, text


def test_every_gpu_command_of_the_plan_is_accepted_and_refused_only_for_want_of_a_gpu(kit, tmp_path, monkeypatch):
    """Each command the kit would run on the node, run here: a misspelt option would end the node's run with exit 2
    too, so the refusal must be the GPU's. The rooms' form factors take minutes here: their commands run on scene
    1 (the same options), with form factors at hemicube R = 16 (the solve does not depend on R)."""
    if gpu_absent_reason(kit) is None:
        pytest.skip("a GPU is present: the kit's own run checks its commands there")
    driver, _ = kit_modules()
    monkeypatch.setattr(driver, "KIT", kit)
    out = tmp_path / "out"
    (out / "ff").mkdir(parents=True)
    env = {"PATH": "/usr/bin:/bin", "LD_LIBRARY_PATH": cublas_dir()}
    for k in (1, 2):
        p = subprocess.run([kit / "bin" / "radiosity", "formfactors", kit / "radiosity" / "scenes" / f"scene{k}.xml",
                            "-o", out / "ff" / f"paper-scene{k}.ff", "--hemicube", "16", "--quiet"], env=env)
        assert p.returncode == 0
    d = driver.Driver(driver.argparse.Namespace(out=str(out), budget=420.0, dry_run=False, json=False))
    d.label = "test"
    scene1 = str(kit / "radiosity" / "scenes" / "scene1.xml")
    seen = set()
    for step in d.plan():
        for c in step.commands:
            argv = [str(x) for x in c.argv]
            if "compute-sanitizer" in argv[0]:
                argv = argv[5:]  # compute-sanitizer --tool T --error-exitcode 9 PROGRAM ...
            if "--backend serial" in " ".join(argv):  # the multigrid's CPU reference
                continue
            if step.group == "formfactors" or argv[0].endswith("solve_tests"):
                continue
            if any(x.endswith(("room2.xml", "room3.xml")) for x in argv):
                argv = [scene1 if x.endswith(("room2.xml", "room3.xml")) else
                        str(out / "ff" / "paper-scene1.ff") if x.endswith(".ff") else x
                        for x in argv if x != "--allow-reflectivity-ge-1"]
            if "--backend openmp" in " ".join(argv) or tuple(argv) in seen:  # the CPU reference; repeats
                continue
            seen.add(tuple(argv))
            p = subprocess.run(argv + ["--quiet"], cwd=kit, env=env, capture_output=True, text=True, timeout=120)
            assert p.returncode == 2 and "needs an NVIDIA GPU" in p.stderr, (argv, p.stderr)
    assert len(seen) >= 60, len(seen)


def test_cuda_libraries_come_from_the_toolkit_first_else_from_the_nvidia_packages_each_on_its_own(tmp_path,
                                                                                               monkeypatch):
    sys.path.insert(0, str(ROOT))
    from gpukit import libs
    toolkit, site = tmp_path / "cuda", tmp_path / "site-packages"
    pkg = site / "nvidia" / "cublas" / "lib"
    for d in (toolkit / "lib64", pkg):
        d.mkdir(parents=True)
        for so in libs.CUDA_SONAMES:
            (d / so).write_bytes(b"")
    monkeypatch.setattr(libs, "DEFAULT_TOOLKIT", str(tmp_path / "no-cuda"))
    monkeypatch.setattr(sys, "path", [str(site)] + sys.path)
    found = libs.find(libs.CUDA_SONAMES, {"CUDA_HOME": str(toolkit)})
    assert set(found.values()) == {(str(toolkit / "lib64"), "the CUDA toolkit (CUDA_HOME/lib64)")}
    where, how = libs.find(["libcublas.so.13"], {})["libcublas.so.13"]
    assert where == str(pkg) and "nvidia CUDA Python packages" in how
    (pkg / "libcusparse.so.12").unlink()  # each library on its own: cuSPARSE missing does not hide cuBLAS
    found = libs.find(libs.CUDA_SONAMES, {})
    assert found["libcublas.so.13"][0] == str(pkg)
    assert found["libcusparse.so.12"][0] is None and found["libcusparse.so.12"][1].startswith("searched ")

