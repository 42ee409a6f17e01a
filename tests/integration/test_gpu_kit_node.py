"""The GPU kit as the GPU node really is (issue 32), checked where there is no GPU: the node's LD_LIBRARY_PATH kept
for the kit's children (a fake libcuda.so.1), a compute-sanitizer that refuses the device as under gVisor, the
driver dying mid-run, late steps dropped by name, and the stand-ins for cuBLAS and cuSPARSE. The kit is the one
test_gpu_kit.py builds (its fixture: make gpu-kit, a no-op when built)."""
import json
import os
import shutil
import signal
import subprocess
import tarfile

import pytest

from test_gpu_kit import gpu_absent_reason, kit, kit_driver, kit_modules  # noqa: F401  (kit: the fixture)

FAKE_LIBCUDA = r"""
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>
/* A stand-in for the node's driver: says which process loaded it, is CUDA 13.0, and has no device. */
__attribute__((constructor)) static void loaded(void) {
  char exe[4096];
  ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
  const char* mark = getenv("FAKE_LIBCUDA_MARK");
  if (n > 0 && mark) {
    exe[n] = 0;
    FILE* f = fopen(mark, "a");
    if (f) { fprintf(f, "%s\n", exe); fclose(f); }
  }
}
int cuDriverGetVersion(int* v) { *v = 13000; return 0; }
int cuInit(unsigned flags) { (void)flags; return 100; } /* CUDA_ERROR_NO_DEVICE */
int cuDeviceGetCount(int* n) { *n = 0; return 0; }
"""


def test_a_copy_run_keeps_the_nodes_ld_library_path_for_its_children(kit, tmp_path):
    """Where the node's libcuda.so.1 is found only through LD_LIBRARY_PATH (issue 32, finding 1), the kit adds to
    that variable: its probe and its programs (child processes) load the driver from there, and its first lines
    say where it found it."""
    if shutil.which("cc") is None:
        pytest.skip("no C compiler here to make the fake libcuda.so.1")
    if gpu_absent_reason(kit) is None:
        pytest.skip("a GPU is present: a fake driver would hide it")
    fake = tmp_path / "node-driver"
    fake.mkdir()
    (tmp_path / "fake.c").write_text(FAKE_LIBCUDA)
    cc = subprocess.run(["cc", "-shared", "-fPIC", "-Wl,-soname,libcuda.so.1", "-o", fake / "libcuda.so.1",
                         tmp_path / "fake.c"], capture_output=True, text=True)
    assert cc.returncode == 0, cc.stderr
    copy = tmp_path / "kit"
    shutil.copytree(kit, copy, symlinks=True)
    mark = tmp_path / "loaded-by.txt"
    env = {"PATH": "/usr/bin:/bin", "LD_LIBRARY_PATH": str(fake), "FAKE_LIBCUDA_MARK": str(mark)}
    p = subprocess.run(["/usr/bin/env", "-i", *(f"{k}={v}" for k, v in env.items()), copy / "run", "--out",
                        tmp_path / "out"], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert p.returncode == 3, p.stdout + p.stderr  # the fake driver has no device: no GPU at all
    head = p.stdout.split("gpu-kit plan:")[0]  # the first lines, before the plan
    assert f"driver: libcuda.so.1 from {fake / 'libcuda.so.1'}, CUDA 13.0: cuInit failed with CUresult 100" in head, \
        p.stdout
    assert "cuBLAS 13: libcublas.so.13 => " in head and "cuSPARSE 12: libcusparse.so.12 => " in head, head
    loaded = mark.read_text().splitlines()
    assert str(copy / "bin" / "poisson") in loaded, loaded  # the GPU probe, a child of the kit, saw the folder
    assert str(copy / "bin" / "radiosity") in loaded, loaded  # so did the form factors of scene 1
    machine = json.loads(next((tmp_path / "out" / "results").glob("*/machine.json")).read_text())
    assert machine["ld_library_path"].split(":")[1] == str(fake), machine["ld_library_path"]


def first_ff(steps):
    """Scene 1's form factors: the step that runs first, GPU or none."""
    return next(s for s in steps if s.group == "formfactors")


FAKE_SANITIZER = """#!/bin/sh
# compute-sanitizer as under gVisor: it refuses the device, then the program fails at its first allocation.
echo "========= COMPUTE-SANITIZER"
echo "========= Error: Device not supported. Please refer to the Supported Devices section of the documentation."
echo "poisson: CUDA error 999 (unknown error) at cudaMalloc" >&2
exit 1
"""


def test_a_sanitizer_that_refuses_the_device_skips_its_steps_with_the_reason_and_exit_is_not_1(kit, tmp_path,
                                                                                              monkeypatch):
    tools = tmp_path / "tools"
    tools.mkdir()
    (tools / "compute-sanitizer").write_text(FAKE_SANITIZER)
    (tools / "compute-sanitizer").chmod(0o755)
    monkeypatch.setenv("PATH", f"{tools}:/usr/bin:/bin")
    driver, d = kit_driver(kit, tmp_path / "out", monkeypatch, 300.0, sanitizer=True)
    steps = d.plan()
    san = [s for s in steps if s.group == "sanitizer"]
    assert len(san) >= 20 and all(s.commands[0].argv[0] == str(tools / "compute-sanitizer") for s in san)
    status = driver.run(d, [first_ff(steps)] + san)  # scene 1's form factors, then every sanitizer step
    assert status == 6, (status, d.failed)  # skipped, not failed
    assert not d.failed and sorted(d.skipped) == sorted(s.name for s in san)
    why = {o.name: o.why for o in d.outcomes}
    assert all("Device not supported" in why[s.name] and "as under gVisor" in why[s.name] for s in san), why
    text = (tmp_path / "out" / "summary.md").read_text()
    assert "compute-sanitizer: " in text and "refuses this GPU (Error: Device not supported." in text
    assert f"- skipped (time, a library or a tool the node lacks): {len(san)}" in text and "- failed: 0" in text


def test_when_a_case_is_killed_a_record_garbled_and_the_driver_dies_the_summary_and_archive_say_so(kit, tmp_path,
                                                                                                  monkeypatch):
    driver, d = kit_driver(kit, tmp_path / "out", monkeypatch, 300.0)
    from gpukit.checks import poisson_converged
    from gpukit.plan import Cmd, Step
    garble = 'printf \'{"schema": "hpcgi-rec\' >> "$2"; echo \'{"half a record\''

    def boom(_rec):
        raise RuntimeError("the driver's own bug")

    steps = [first_ff(d.plan()),
             Step("a case killed", "table41", 1, [Cmd(["sh", "-c", "kill -9 $$"])]),
             Step("a garbled record", "table41", 1, [Cmd(["sh", "-c", garble, "sh"], "table41", "test/1",
                                                         poisson_converged, True)]),
             Step("the driver dies here", "table41", 1, [Cmd(["sh", "-c", "echo '{}'"], None, None, boom, True)]),
             Step("never reached", "table41", 1, [Cmd(["true"])])]
    assert driver.run(d, steps) == 1
    text = (tmp_path / "out" / "summary.md").read_text()
    assert "| a case killed | table41 | 1 |" in text and "killed by SIGKILL" in text, text
    assert "printed a garbled record" in text, text
    assert "The driver stopped before its end: RuntimeError: the driver's own bug" in text, text
    assert "never reached" not in text
    assert "1 record lines are no JSON object" in text and "table41/paper.jsonl:1" in text, text
    with tarfile.open(tmp_path / "out" / "gpu-kit-test-fake-gpu-node.tar.gz") as t:
        names = set(t.getnames())
        records = t.extractfile("results/test-fake-gpu-node/table41/paper.jsonl").read().decode()
        garbled = t.extractfile("logs/garbled-records.txt").read().decode()
    assert {"summary.md", "logs/driver-traceback.txt", "logs/progress.log"} <= names, names
    assert records == "", records  # the garbled line set aside: the archive's records import
    assert '"schema": "hpcgi-rec' in garbled
    # told to stop (the call's end): SIGTERM mid-step, and the summary and the archive are still written
    driver, d = kit_driver(kit, tmp_path / "out", monkeypatch, 300.0)  # the same folder: scene 1's F is made
    term = lambda _rec: os.kill(os.getpid(), signal.SIGTERM)
    assert driver.run(d, [first_ff(d.plan()), Step("stopped here", "table41", 1, [
        Cmd(["sh", "-c", "echo '{}'"], None, None, term, True)])]) == 1
    text = (tmp_path / "out" / "summary.md").read_text()
    assert "The driver stopped before its end: Stopped: told to stop by SIGTERM" in text, text
    assert signal.getsignal(signal.SIGTERM) == signal.SIG_DFL  # the driver's handler is gone again


def test_running_late_defers_the_last_steps_by_name_and_runs_them_if_time_is_left(tmp_path, monkeypatch):
    driver, _ = kit_modules()
    from gpukit.plan import Cmd, Outcome, Step
    d = driver.Driver(driver.argparse.Namespace(out=str(tmp_path), budget=80.5, dry_run=False, json=False))
    d.outcomes = [Outcome("first", "x", 10, "ok", 30.0)]  # measured: three times its estimate
    assert d.pace() == 3.0
    queue = [Step(f"step {k}", "x", 10, [Cmd(["true"])]) for k in range(4)]
    deferred = []
    d.defer_late(queue, deferred)  # 70.5 s left before the reserve: 2 of the 4 fit at 3 s a second
    assert [s.name for s in queue] == ["step 0", "step 1"] and [s.name for s in deferred] == ["step 2", "step 3"]
    # run_all: a deferred step that still does not fit at the end is skipped with the reason, by name
    ran = []
    monkeypatch.setattr(d, "run_step", lambda s: ran.append(s.name))
    monkeypatch.setattr(d, "skip_reason", lambda s: "5 s left, it needs about 30 s")
    d.run_all([Step(f"step {k}", "x", 10, [Cmd(["true"])]) for k in range(4)])
    assert ran == ["step 0", "step 1", "step 2"], ran
    assert d.skipped == ["step 3"] and "deferred (running late at 3.00 times the estimates)" in d.outcomes[-1].why
    # where the pace then leaves room, the deferred step runs after all, last
    d2 = driver.Driver(driver.argparse.Namespace(out=str(tmp_path), budget=80.5, dry_run=False, json=False))
    d2.outcomes = [Outcome("first", "x", 10, "ok", 30.0)]
    ran2, said = [], []

    def then_fast(step):  # step 0 at three times its estimate (step 3 is deferred), the others at a tenth
        ran2.append(step.name)
        d2.outcomes.append(Outcome(step.name, "x", 10, "ok", 30.0 if step.name == "step 0" else 1.0))
    monkeypatch.setattr(d2, "run_step", then_fast)
    monkeypatch.setattr(d2, "say", said.append)
    d2.run_all([Step(f"step {k}", "x", 10, [Cmd(["true"])]) for k in range(4)])
    assert any("deferring the last 1 steps to the end: step 3" in m for m in said), said
    assert ran2 == ["step 0", "step 1", "step 2", "step 3"], ran2


def test_without_cublas_the_kits_stand_ins_let_the_programs_start_and_only_cublas_steps_are_skipped(kit, tmp_path,
                                                                                                  monkeypatch):
    """A node without cuBLAS (or cuSPARSE) runs what needs neither: the kit's stand-ins (lib/stubs) satisfy the
    loader, and the steps that use the library are skipped with the reason (finding 4 of issue 32)."""
    stubs = kit / "lib" / "stubs"
    # ahead of the loader's cache, as the kit puts them on such a node
    env = {"PATH": "/usr/bin:/bin", "LD_LIBRARY_PATH": f"{stubs / 'cublas'}:{stubs / 'cusparse'}"}
    out = subprocess.run(["ldd", kit / "bin" / "radiosity"], env=env, capture_output=True, text=True)
    assert f"libcublas.so.13 => {stubs / 'cublas' / 'libcublas.so.13'}" in out.stdout, out.stdout
    assert f"libcusparse.so.12 => {stubs / 'cusparse' / 'libcusparse.so.12'}" in out.stdout, out.stdout
    assert "no version information" not in out.stdout + out.stderr, out.stderr
    for argv in (["poisson", "--backend", "openmp", "--n", "32", "--quiet"], ["radiosity", "--help"]):
        p = subprocess.run([kit / "bin" / argv[0], *argv[1:]], env=env, capture_output=True, text=True)
        assert p.returncode == 0 and p.stderr == "", (argv, p.stderr)
    _, d = kit_driver(kit, tmp_path / "out", monkeypatch, 420.0)
    d.missing = {"cublas": "cuBLAS 13: libcublas.so.13, libcublasLt.so.13 not found"}
    reasons = {s.name: d.skip_reason(s) for s in d.plan()}
    assert reasons["Poisson CG cuBLAS against the CPU at N = 256"] == ("the node lacks it: cuBLAS 13: "
                                                                       "libcublas.so.13, libcublasLt.so.13 not found")
    assert reasons["Poisson CG cuda against the CPU at N = 256"] is None
    assert reasons["cuda csr against float64 on scene 1"] is None  # cuSPARSE is there
    assert reasons["cublas csr against float64 on scene 1"].startswith("the node lacks it: cuBLAS 13")
    lacking = [n for n, why in reasons.items() if why]
    assert "GPU unit tests (solve_tests --gtest_filter='Cuda*')" in lacking  # they test cublas too
    assert all("cublas" in n.lower() for n in lacking if "unit tests" not in n) and len(lacking) >= 20, lacking
    # the driver's probe puts the stand-in of a missing library ahead of the node's folders, and only that one
    from gpukit import libs, node, probe
    gone = "cuBLAS 13: libcublas.so.13 not found"
    monkeypatch.setattr(probe, "missing_libraries", lambda binaries, env: (
        ({}, []) if str(stubs / "cublas") in env["LD_LIBRARY_PATH"] else ({"cublas": gone}, [])))
    monkeypatch.setattr(libs, "find", lambda sonames, environ=None: {so: (None, "searched nowhere") for so in sonames})
    monkeypatch.setenv("LD_LIBRARY_PATH", "/node/driver")
    _, d = kit_driver(kit, tmp_path / "out2", monkeypatch, 420.0)
    assert node.probe_libraries(d, kit) is True
    assert d.env["LD_LIBRARY_PATH"].split(":") == [str(kit / "lib"), str(stubs / "cublas"), "/node/driver"]
    assert d.missing == {"cublas": gone} and d.found[0].startswith(gone + " (searched nowhere"), d.found
