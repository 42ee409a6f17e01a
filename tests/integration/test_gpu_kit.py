"""The GPU kit (make gpu-kit, gpu-kit/run, make gpu-import), checked where there is no GPU: the folder's size and
libraries, the dry-run plan against the case lists, a run from a copy in a clean environment (the CPU step, "no
GPU", exit 3, nothing written outside its output folder), and the import of an archive with a fake GPU."""
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
    p = run(["make", "--no-print-directory", "gpu-kit"], cwd=ROOT, timeout=3600)
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
    p = run(["make", "--no-print-directory", "gpu-kit", f"RRV_SCENES={tmp_path}", f"KIT={tmp_path / 'kit'}"], cwd=ROOT)
    assert p.returncode == 2
    assert p.stderr.splitlines()[0] == (f"make gpu-kit: the kit carries RRV's scenes, and {tmp_path} lacks room2.xml, "
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


def test_dry_run_fits_80_percent_of_its_budget_and_lists_the_case_lists_gpu_cases(kit):
    p = clean_run([kit / "run", "--dry-run", "--json"], cwd=kit)
    assert p.returncode == 0, p.stderr
    plan = json.loads(p.stdout)
    assert [(c["experiment"], c["index"], c["line"]) for c in plan["gpu_cases"]] == paper_gpu_cases()
    assert len(plan["gpu_cases"]) == 39  # 35 of the report's tables, 4 of MG-PCG (Table 4.1's cuda column)
    names = [s["name"] for s in plan["steps"]]
    for exp, k, line in paper_gpu_cases():
        assert f"{exp} case {k}: {line}" in names
    assert all(s["estimate_s"] > 0 for s in plan["steps"])
    planned = [s for s in plan["steps"] if not s["optional"]]
    assert plan["slack"] >= 0.2
    assert sum(s["estimate_s"] for s in planned) + plan["reserve_s"] <= 0.8 * 420  # at least 20% slack
    first_optional = next(k for k, s in enumerate(plan["steps"]) if s["optional"])
    assert all(s["optional"] for s in plan["steps"][first_optional:]), "the optional steps come last"
    text = clean_run([kit / "run", "--dry-run"], cwd=kit)
    assert text.returncode == 0 and "skip (budget)" not in text.stdout, text.stdout
    total = re.search(r"total of the steps that fit: (\d+) s of (\d+) s", text.stdout)
    assert total and int(total.group(1)) <= 0.8 * 420 - plan["reserve_s"], text.stdout
    for s in plan["steps"]:
        what = "if early" if s["optional"] else "run"
        assert re.search(rf"^\s*{s['estimate_s']} s\s+{what}\s+\[{re.escape(s['group'])}\] {re.escape(s['name'])}$",
                         text.stdout, re.M), s
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


def fake_out(out, label, gpu="TEST fake GPU (tests/integration/test_gpu_kit.py)", machine_id="7e57000000000001"):
    """A kit's output folder with two records of a fake GPU, marked as a test, as gpu-kit/run leaves it (its
    machine.json carrying the node's machine_id)."""
    rec = lambda i: {"schema": "hpcgi-record/1", "app": "poisson", "params": {"n": 64 * i, "backend": "cuda"},
                     "result": {"converged": True}, "times_s": {"solve": 0.1 * i},
                     "backend_info": {"gpu": gpu},
                     "provenance": {"git_commit": "test", "git_dirty": False, "compiler": "test", "host": "test",
                                    "os": "test", "cpu_model": "test", "cpus_online": 1, "utc": "2026-01-01T00:00:00Z",
                                    "env": {"HPCGI_CASE": f"test/{i}"}}}  # a valid record (tests/conftest.py)
    d = out / "results" / label / "table41"
    d.mkdir(parents=True)
    (d / "paper.jsonl").write_text("".join(json.dumps(rec(i)) + "\n" for i in (1, 2)))
    (out / "results" / label / "machine.json").write_text(json.dumps({"label": label, "gpu": gpu,
                                                                     "machine_id": machine_id}))
    (out / "logs").mkdir()
    (out / "logs" / "progress.log").write_text("test\n")
    (out / "summary.md").write_text("# test\n")
    sys.path.insert(0, str(ROOT))
    from gpukit import driver
    return driver.pack_archive(out, label)


def gpu_import(archive, results):
    return run(["make", "--no-print-directory", "gpu-import", f"ARCHIVE={archive}", f"RESULTS={results}"], cwd=ROOT)


def test_gpu_import_puts_records_under_the_node_label_append_only(tmp_path):
    label = "test-fake-gpu-node"
    archive = fake_out(tmp_path / "out", label)
    results = tmp_path / "results"
    p = gpu_import(archive, results)
    assert p.returncode == 0, p.stderr
    target = results / label / "table41" / "paper.jsonl"
    lines = target.read_text().splitlines()
    assert [json.loads(l)["params"]["n"] for l in lines] == [64, 128]
    assert json.loads((results / label / "machine.json").read_text())["gpu"].startswith("TEST fake GPU")
    target.write_text(target.read_text() + '{"schema":"hpcgi-record/1","earlier":true}\n')  # a record already there
    old = target.read_bytes()
    p = gpu_import(archive, results)  # again: nothing twice, nothing changed
    assert p.returncode == 0 and "0 records" in p.stdout, p.stdout + p.stderr
    assert target.read_bytes() == old
    shutil.rmtree(results / label)  # the fake GPU's records are removed


def test_gpu_import_refuses_a_truncated_archive_or_a_record_without_gpu_with_one_line(tmp_path):
    archive = fake_out(tmp_path / "out", "test-fake-gpu-node")
    cut = tmp_path / "cut.tar.gz"
    cut.write_bytes(archive.read_bytes()[: archive.stat().st_size // 2])
    results = tmp_path / "results"
    p = gpu_import(cut, results)
    assert p.returncode != 0 and "truncated or damaged" in p.stderr, p.stderr
    own = [l for l in p.stderr.splitlines() if not re.match(r"make(\[\d+\])?: ", l)]  # less make's own aside
    assert len(own) == 1, p.stderr
    assert not results.exists()
    no_gpu = fake_out(tmp_path / "out2", "test-fake-gpu-node", gpu="")
    p = gpu_import(no_gpu, results)
    assert p.returncode != 0 and "names no GPU" in p.stderr, p.stderr
    assert not results.exists()
    out3 = tmp_path / "out3"  # the machine has a GPU, one record does not: nothing is imported
    fake_out(out3, "test-fake-gpu-node")
    records = out3 / "results" / "test-fake-gpu-node" / "table41" / "paper.jsonl"
    cpu = json.loads(records.read_text().splitlines()[0])
    cpu["backend_info"] = {"threads": "16"}
    records.write_text(records.read_text() + json.dumps(cpu) + "\n")
    sys.path.insert(0, str(ROOT))
    from gpukit import driver
    p = gpu_import(driver.pack_archive(out3, "test-fake-gpu-node"), results)
    assert p.returncode != 0 and "table41/paper.jsonl:3 carries no GPU" in p.stderr, p.stderr
    assert len([l for l in p.stderr.splitlines() if not re.match(r"make(\[\d+\])?: ", l)]) == 1, p.stderr
    assert not results.exists()


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
    for s in steps[1:]:  # every step after scene 1's form factors estimated past the budget (this machine is slow)
        s.estimate_s = 10_000
    assert driver.run(d, steps) == 6  # skipped steps: not all ran, and nothing failed
    assert [n for n, _, _ in d.done] == ["form factors of scene1.xml"]
    assert sorted(d.skipped) == sorted(s.name for s in steps[1:]) and not d.failed
    archive = tmp_path / "out" / "gpu-kit-test-fake-gpu-node.tar.gz"
    assert archive.stat().st_size <= 16 * 2**20
    with tarfile.open(archive) as t:
        names = t.getnames()
    assert {"summary.md", "logs/progress.log", "results/test-fake-gpu-node/machine.json"} <= set(names), names
    text = (tmp_path / "out" / "summary.md").read_text()
    assert f"- skipped (time, a library or a tool the node lacks): {len(steps) - 1}" in text
    # the plan's estimate beside each step
    assert "| 1 | form factors of scene1.xml | formfactors | 1 | " in text, text


def gpu_record(path, **change):
    """A committed CPU record of this project reshaped as a GPU run: the record layout the summary reads."""
    rec = json.loads((ROOT / path).read_text().splitlines()[0])
    for key, value in change.items():
        part, field = key.split("__")
        rec.setdefault(part, {})[field] = value
    rec["backend_info"]["gpu"] = "TEST fake GPU (tests/integration/test_gpu_kit.py)"
    return rec


def test_summary_judges_the_speed_targets_from_records_that_count(tmp_path):
    _, summary = kit_modules()
    res = tmp_path / "results"
    t41 = ROOT / "results" / "vm-amd-epyc-2c" / "table41" / "quick.jsonl"
    t43 = ROOT / "results" / "vm-amd-epyc-2c" / "table43" / "quick.jsonl"
    made = tmp_path / "stream.jsonl"  # a stream record of this build (the reference has none committed)
    assert run([ROOT / "bin" / "stream", "--size", "100000", "--trials", "1", "--quiet", "--record", made]).returncode == 0
    stream = gpu_record(made, perf__triad_GBps=4000.0, perf__read_GBps=4200.0)
    cg = gpu_record(t41, params__n=8192, params__backend="cuda", times_s__solve=12.5, params__precond="none",
                    result__iterations=12600)
    slow = gpu_record(t41, params__n=8192, params__backend="cublas1", times_s__solve=30.0, result__converged=False)
    # MG-PCG at the same N, listed last (as in the case list): the CG target must not read it
    mg = gpu_record(t41, params__n=8192, params__backend="cuda", times_s__solve=3.0, params__precond="mg",
                    result__iterations=7)
    jac = gpu_record(t43, params__scene="/kit/scenes/rrv/room2.xml", params__backend="cuda", times_s__solve=0.010,
                     perf__bandwidth_GBps=3500.0, result__status="steps_done", result__iterations=32)
    for exp, recs in (("gpu-stream", [stream]), ("table41", [cg, slow, mg]), ("table43-steps32", [jac])):
        (res / exp).mkdir(parents=True)
        (res / exp / "paper.jsonl").write_text("".join(json.dumps(r) + "\n" for r in recs))
    text = summary.write(res, ROOT / "results" / "paper")
    assert "triad 4000 GB/s" in text
    assert ("Poisson plain CG N = 8192, cuda: 12.50 s, 12600 iterations (target <= 15 s on an H200; report 747 s with "
            "cuBLAS 1): holds") in text
    assert "Poisson MG-PCG N = 8192, cuda (no target; beside plain CG): 3.00 s, 7 iterations" in text
    assert "Jacobi, scene 4, 32 steps, cuda, float32 F, dense: 10.00 ms" in text
    assert "88% of the triad (target >= 85%): holds" in text
    assert "Jacobi, scene 4, 32 steps, cuda, float16 F, compressed: not measured" in text
    assert [l for l in text.splitlines() if l.startswith("| cuda | mg | 8192 | 7 |")], text  # labelled MG
    row = [l for l in text.splitlines() if l.startswith("| cublas1 | none | 8192 |")]
    assert len(row) == 1 and row[0].endswith("| NO |"), row  # did not converge: listed, not counted
    assert "| 747" in row[0] or "747" in row[0]


def test_the_checks_of_the_correctness_steps():
    sys.path.insert(0, str(ROOT))
    from gpukit import checks as driver
    rec = lambda be, it, e, variant="onesweep": {"params": {"backend": be, "variant": variant},
                                                 "result": {"iterations": it, "error_inf": e}}
    assert driver.poisson_agree([rec("openmp", 1581, 3.1416e-6), rec("cuda", 1582, 3.1417e-6)]) is None
    assert "iterations" in driver.poisson_agree([rec("openmp", 1581, 3.1416e-6), rec("cuda", 1583, 3.1416e-6)])
    assert "4 digits" in driver.poisson_agree([rec("openmp", 1581, 3.1416e-6), rec("cublas1", 1581, 3.15e-6)])
    assert driver.sanitizer_clean("========= ERROR SUMMARY: 0 errors\n") is None
    assert driver.sanitizer_clean("========= RACECHECK SUMMARY: 0 hazards displayed (0 errors, 0 warnings)\n") is None
    assert "2 hazards" in driver.sanitizer_clean("========= RACECHECK SUMMARY: 2 hazards displayed (2 errors, 0 "
                                                 "warnings)\n")
    assert driver.sanitizer_clean("no summary at all") == "compute-sanitizer: no summary line"
    assert driver.gpu_tests_ran("[  SKIPPED ] the GPU backends cannot run here: ...") is not None
    ok = {"result": {"status": "converged"}, "verify": {"agreed": True}}
    assert driver.converged_and_agreed(ok) is None
    assert "float64" in driver.converged_and_agreed({"result": {"status": "converged"}, "verify": {"agreed": False}})
    assert "max_iter" in driver.converged_and_agreed({"result": {"status": "max_iter"}, "verify": None})
    # the GPU multigrid against serial's: iterations within 1, the error to 4 digits, a symmetric V-cycle
    mg = lambda be, it, e: {"params": {"backend": be, "variant": "classic", "precond": "mg"},
                            "result": {"iterations": it, "error_inf": e, "converged": True, "mg_asymmetry": 1e-15}}
    assert driver.poisson_agree([mg("serial", 6, 3.1416e-6), mg("cuda", 7, 3.1417e-6)]) is None
    why = driver.poisson_agree([mg("serial", 6, 3.1416e-6), mg("cuda", 8, 3.1416e-6)])
    assert why == "cuda classic --precond mg: 8 iterations, serial classic --precond mg 6", why
    assert "4 digits" in driver.poisson_agree([mg("serial", 6, 3.1416e-6), mg("cuda", 6, 3.2e-6)])
    assert driver.mg_symmetric(mg("cuda", 6, 1.0)) is None
    skew = mg("cuda", 6, 1.0)
    skew["result"]["mg_asymmetry"] = 1e-6
    assert "not symmetric" in driver.mg_symmetric(skew)
    del skew["result"]["mg_asymmetry"]
    assert "--check-symmetry" in driver.mg_symmetric(skew)
    assert driver.poisson_agree([mg("serial", 6, 1.0), None]) == "a run printed no record"
    # compute-sanitizer refusing the device (gVisor) is told apart from an error it finds
    assert driver.sanitizer_refusal("========= Error: Device not supported.\n") == "Error: Device not supported."
    assert driver.sanitizer_refusal("========= ERROR SUMMARY: 3 errors\n") is None


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

