"""What the GPU kit brings back from the node, checked without a GPU or a built kit: make gpu-import of an archive
from a fake GPU (append-only, under the node's label; a truncated archive or a record without a GPU refused with one
line), the summary's speed targets judged from records that count, and the checks of the correctness steps.
The kit itself is tested in test_gpu_kit.py."""
import json
import re
import shutil
import sys

from conftest import ROOT, run
from test_gpu_kit import kit_modules


def fake_out(out, label, gpu="TEST fake GPU (tests/integration/test_gpu_kit.py)", machine_id="7e57000000000001"):
    """A kit's output folder with two records of a fake GPU, marked as a test, as gpu-kit/run leaves it (its
    machine.json carrying the node's machine_id)."""
    rec = lambda i: {"schema": "hpcgi-record/1", "app": "poisson", "params": {"n": 64 * i, "backend": "cuda"},
                     "result": {"converged": True}, "times_s": {"solve": 0.1 * i},
                     "backend_info": {"gpu": gpu},
                     "provenance": {"git_commit": "test", "git_dirty": False, "compiler": "test", "host": "test",
                                    "os": "test", "cpu_model": "test", "cpus_online": 1, "utc": "2026-01-01T00:00:00Z",
                                    "env": {"HPCGI_CASE": f"test/{i}", "HPCGI_MACHINE_ID": machine_id}}}
    # a valid record (tests/conftest.py), made by the node
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


def test_gpu_import_refuses_a_truncated_archive_or_another_machines_record_with_one_line(tmp_path):
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
    sys.path.insert(0, str(ROOT))
    from gpukit import driver
    for what, change, why in (
            ("another machine's record", lambda r: r["provenance"]["env"].update(HPCGI_MACHINE_ID="0123456789abcdef"),
             "table41/paper.jsonl:3 was not made by the machine of the archive's machine.json"),
            ("a record of another GPU", lambda r: r["backend_info"].update(gpu="NVIDIA A100-SXM4-40GB"),
             "table41/paper.jsonl:3 names the GPU 'NVIDIA A100-SXM4-40GB', not the node's")):
        out3 = tmp_path / what.replace(" ", "-")  # one bad record among good ones: nothing is imported
        fake_out(out3, "test-fake-gpu-node")
        records = out3 / "results" / "test-fake-gpu-node" / "table41" / "paper.jsonl"
        bad = json.loads(records.read_text().splitlines()[0])
        change(bad)
        records.write_text(records.read_text() + json.dumps(bad) + "\n")
        p = gpu_import(driver.pack_archive(out3, "test-fake-gpu-node"), results)
        assert p.returncode != 0 and why in p.stderr, (what, p.stderr)
        assert len([l for l in p.stderr.splitlines() if not re.match(r"make(\[\d+\])?: ", l)]) == 1, p.stderr
        assert not results.exists()
    # a CPU run the kit made on the node beside its GPU runs (an OpenMP cell a GPU claim compares with) is the
    # node's record too: it names no GPU and is imported
    out4 = tmp_path / "out4"
    fake_out(out4, "test-fake-gpu-node")
    records = out4 / "results" / "test-fake-gpu-node" / "table41" / "paper.jsonl"
    cpu = json.loads(records.read_text().splitlines()[0])
    cpu["backend_info"], cpu["params"]["backend"] = {"threads": "16"}, "openmp"
    records.write_text(records.read_text() + json.dumps(cpu) + "\n")
    p = gpu_import(driver.pack_archive(out4, "test-fake-gpu-node"), results)
    assert p.returncode == 0 and "3 records" in p.stdout, p.stdout + p.stderr
    shutil.rmtree(results)


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
