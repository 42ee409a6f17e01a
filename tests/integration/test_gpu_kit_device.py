"""The one call on a lent GPU machine (issue 47), checked where there is no GPU: gpu-kit/device-run with a fake $OUT
leaves there at most 8 files, each under 16 MiB, none in a folder, whether the kit ends by itself, is cut short by
the limit or is told to stop; nothing it started is left running; the fake GPU's archive imports with make gpu-import
and make report then fills the GPU cells and decides the GPU claims; make gpu-kit refuses a dirty tree and prints
the device call. The fake GPU node (its programs run on the CPU, recorded as the GPU backends on "TEST fake GPU") is
tests/integration/fake_gpu.py; the kit is test_gpu_kit.py's fixture."""
import json
import os
import re
import shutil
import signal
import subprocess
import tarfile
import time
from pathlib import Path

import pytest

import fake_gpu
from conftest import ROOT, run
from test_gpu_kit import gpu_absent_reason, kit  # noqa: F401  (kit: the fixture)
from test_gpu_kit_node import FAKE_LIBCUDA

BACK = {"nvidia-smi-before.txt", "nvidia-smi-after.txt", "progress.log", "summary.md"}  # and the archive


def comes_back(out):
    """What the lent machine would bring back from `out`, checked against its limits; the names."""
    entries = list(Path(out).iterdir())
    assert all(p.is_file() for p in entries), [p.name for p in entries if not p.is_file()]
    assert len(entries) <= 8, [p.name for p in entries]
    assert all(p.stat().st_size < 16 * 2**20 for p in entries), [(p.name, p.stat().st_size) for p in entries]
    return {p.name for p in entries}


def left_running(marker):
    """Processes whose command line or working folder holds `marker` (the test's own folder)."""
    found = []
    for d in os.listdir("/proc"):
        if not d.isdigit() or int(d) == os.getpid():
            continue
        try:
            cmd = Path(f"/proc/{d}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
            cwd = os.readlink(f"/proc/{d}/cwd")
        except OSError:
            continue
        if str(marker) in cmd or cwd.startswith(str(marker)):
            found.append((d, cmd[:200]))
    return found


def fake_node(kit, tmp):
    copy = tmp / "kit"
    shutil.copytree(kit, copy, symlinks=True)
    return copy, fake_gpu.install(copy, tmp)


def device_run(copy, env, out, *args, timeout=600):
    out.mkdir(exist_ok=True)
    return subprocess.run(["/usr/bin/env", "-i", *(f"{k}={v}" for k, v in {**env, "OUT": str(out)}.items()),
                           copy / "device-run", *map(str, args)], cwd=copy.parent, capture_output=True, text=True,
                          timeout=timeout)


def test_without_a_gpu_device_run_brings_back_five_small_files_and_keeps_its_work_elsewhere(kit, tmp_path):
    if shutil.which("cc") is None:
        pytest.skip("no C compiler here to make the fake libcuda.so.1")
    if gpu_absent_reason(kit) is None:
        pytest.skip("a GPU is present: a fake driver would hide it")
    fake = tmp_path / "node-driver"
    fake.mkdir()
    (tmp_path / "fake.c").write_text(FAKE_LIBCUDA)
    assert subprocess.run(["cc", "-shared", "-fPIC", "-Wl,-soname,libcuda.so.1", "-o", fake / "libcuda.so.1",
                           tmp_path / "fake.c"]).returncode == 0
    copy = tmp_path / "kit"
    shutil.copytree(kit, copy, symlinks=True)
    env = {"PATH": "/usr/bin:/bin", "LD_LIBRARY_PATH": str(fake), "TMPDIR": str(tmp_path)}
    p = device_run(copy, env, tmp_path / "out", "--limit", "120")
    assert p.returncode == 3, p.stdout[-2000:] + p.stderr[-2000:]  # the fake driver has no device
    names = comes_back(tmp_path / "out")
    archive = [n for n in names if n.startswith("gpu-kit-") and n.endswith(".tar.gz")]
    assert names == BACK | set(archive) and len(archive) == 1, names
    assert (tmp_path / "gpu-kit-work" / "ff" / "paper-scene1.ff").is_file()  # the work folder: $TMPDIR, not $OUT
    log = (tmp_path / "out" / "progress.log").read_text()
    assert "ok form factors of scene1.xml" in log and "device-run [" in log and "the kit exited 3" in log, log
    assert "nvidia-smi: not found" in (tmp_path / "out" / "nvidia-smi-before.txt").read_text()
    assert not left_running(tmp_path)


def test_bad_arguments_are_refused_with_one_line_and_nothing_written(kit, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    for args, env, why in ((["--limit", "60"], {"OUT": str(out)}, "--limit must be at least"),
                           ([], {}, "say where the files that come back go"),
                           (["--work", str(out / "w")], {"OUT": str(out)}, "is inside the output folder"),
                           ([], {"OUT": str(out), "DEVICE_LIMIT_S": "soon"}, "is no number of seconds")):
        p = subprocess.run([kit / "device-run", *args], env={"PATH": "/usr/bin:/bin", **env}, capture_output=True,
                           text=True, timeout=60)
        assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1 and why in p.stderr, (args, p.stderr)
        assert not list(out.iterdir()), "nothing is written on a refusal"


@pytest.fixture(scope="module")
def fake_gpu_run(kit, tmp_path_factory):
    """device-run of the ci preset on the fake GPU node: (its folder, the process, the out folder)."""
    if shutil.which("cc") is None:
        pytest.skip("no C compiler here to make the fake NVML")
    tmp = tmp_path_factory.mktemp("fake-gpu")
    copy, env = fake_node(kit, tmp)
    p = device_run(copy, env, tmp / "out", "--limit", "300", "--preset", "ci")
    return tmp, p, tmp / "out"


def test_on_a_fake_gpu_device_run_brings_back_the_archive_and_nothing_is_left_running(fake_gpu_run):
    tmp, p, out = fake_gpu_run
    assert p.returncode in (0, 1, 6), p.stdout[-3000:] + p.stderr[-3000:]
    names = comes_back(out)
    archive = [n for n in names if n.endswith(".tar.gz")]
    assert names == BACK | set(archive) and len(archive) == 1, names
    summary = (out / "summary.md").read_text()
    assert "## The GPU beside the runs" in summary and "| before the runs | 1980-1980 | 2619-2619 | 45-45 |" in summary
    with tarfile.open(out / archive[0]) as t:
        members = t.getnames()
    assert any(m.endswith("table41/ci.state.jsonl") for m in members), members
    assert not left_running(tmp)


def test_the_fake_gpus_archive_imports_and_make_report_fills_the_gpu_cells_and_decides_gpu_claims(fake_gpu_run):
    tmp, _, out = fake_gpu_run
    archive = next(out.glob("gpu-kit-*.tar.gz"))
    results = tmp / "results"
    p = run(["make", "--no-print-directory", "gpu-import", f"ARCHIVE={archive}", f"RESULTS={results}"], cwd=ROOT)
    assert p.returncode == 0, p.stderr
    label = archive.name[len("gpu-kit-"):-len(".tar.gz")]
    state = [json.loads(l) for l in (results / label / "table41" / "ci.state.jsonl").read_text().splitlines()]
    assert state and all(s["gpu_before"]["sm_MHz"] == 1980 and s["disturbed"] is False for s in state)
    rounds = {}
    for line in (results / label / "table41" / "ci.jsonl").read_text().splitlines():
        env = json.loads(line)["provenance"]["env"]
        rounds.setdefault(env["HPCGI_CASE"], set()).add(env["HPCGI_REPEAT"])
    assert {"0", "1", "2", "3", "4", "5"} in rounds.values(), rounds  # a claim's cells: six paired rounds
    manifest = json.loads((tmp / "kit" / "KIT-MANIFEST.json").read_text())
    env = {"RESULTS": str(results), **({"ANALYSIS_ALL_RECORDS": "1"} if manifest["git_dirty"] else {})}
    p = run(["make", "--no-print-directory", "report", f"MACHINE={label}", "PRESET=ci"], cwd=ROOT, env=env,
            timeout=600)
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    report = (results / "report" / label / "REPORT-ci.md").read_text()
    t41 = next(l for l in report.splitlines() if l.startswith("| 16 |"))
    assert "n=6" in t41, t41  # the cuBLAS cells of Table 4.1, six rounds each
    claims = [l for l in report.splitlines() if l.startswith("| CUDA with SOA (cuBLAS) is faster than CUDA with AOS")]
    assert claims and "not run" not in claims[0] and "6 pairs, interleaved" in claims[0], claims


def test_a_limit_that_cuts_the_run_short_still_brings_back_its_files(kit, tmp_path):
    """The paper preset on the fake GPU's CPUs cannot end in 75 s: the kit's budget (15 s) stops it, its summary and
    archive are made, and device-run ends well inside the limit with nothing left running."""
    if shutil.which("cc") is None:
        pytest.skip("no C compiler here to make the fake NVML")
    copy, env = fake_node(kit, tmp_path)
    t = time.monotonic()
    p = device_run(copy, env, tmp_path / "out", "--limit", "75", timeout=120)
    took = time.monotonic() - t
    assert took < 75, took
    assert p.returncode in (1, 6), p.stdout[-2000:] + p.stderr[-2000:]
    names = comes_back(tmp_path / "out")
    assert BACK <= names and any(n.endswith(".tar.gz") for n in names), names
    assert "skipped" in (tmp_path / "out" / "summary.md").read_text()
    assert not left_running(tmp_path)


def test_sigterm_to_device_run_still_brings_back_the_summary_and_the_archive(kit, tmp_path):
    if shutil.which("cc") is None:
        pytest.skip("no C compiler here to make the fake NVML")
    copy, env = fake_node(kit, tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    p = subprocess.Popen(["/usr/bin/env", "-i", *(f"{k}={v}" for k, v in {**env, "OUT": str(out)}.items()),
                          copy / "device-run", "--limit", "300"], cwd=tmp_path, stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, text=True)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and "form factors of scene1.xml" not in (
            (tmp_path / "gpu-kit-work" / "logs" / "progress.log").read_text()
            if (tmp_path / "gpu-kit-work" / "logs" / "progress.log").exists() else ""):
        time.sleep(0.5)
    p.send_signal(signal.SIGTERM)
    text, _ = p.communicate(timeout=120)
    assert p.returncode == 1, text[-2000:]
    names = comes_back(out)
    assert BACK <= names and any(n.endswith(".tar.gz") for n in names), names
    assert "told to stop by SIGTERM" in (out / "summary.md").read_text()
    assert "told to stop by SIGTERM: SIGTERM to it" in (out / "progress.log").read_text()
    assert not left_running(tmp_path)


def test_gpu_state_flags_a_run_made_during_a_thermal_slowdown(tmp_path):
    """NVML's clock reasons beside a run (gpukit/gpu_state.py): a thermal slowdown marks it disturbed, the power
    cap does not."""
    if shutil.which("cc") is None:
        pytest.skip("no C compiler here to make the fake NVML")
    (tmp_path / "nvml.c").write_text(fake_gpu.FAKE_NVML)
    assert subprocess.run(["cc", "-shared", "-fPIC", "-o", tmp_path / "libnvidia-ml.so.1",
                           tmp_path / "nvml.c"]).returncode == 0
    probe = ("import json, sys; sys.path.insert(0, sys.argv[1]); from gpukit import gpu_state as g; "
             "s = g.Nvml.open().sample(); print(json.dumps([s, g.disturbed(s, s)]))")
    got = {}
    for bits in ("0x4", "0x20"):
        p = subprocess.run(["python3", "-c", probe, str(ROOT)], capture_output=True, text=True,
                           env={"PATH": "/usr/bin:/bin", "LD_LIBRARY_PATH": str(tmp_path), "FAKE_NVML_REASONS": bits})
        assert p.returncode == 0, p.stderr
        got[bits] = json.loads(p.stdout)
    assert got["0x4"][0]["reasons_text"] == "sw power cap" and got["0x4"][1] == [False, None]
    assert got["0x20"][1][0] is True and "sw thermal slowdown" in got["0x20"][1][1]
    assert got["0x20"][0]["sm_MHz"] == 1980 and got["0x20"][0]["temperature_C"] == 45


def test_make_gpu_kit_refuses_a_dirty_tree_and_prints_the_device_call(kit, tmp_path):
    clone = tmp_path / "clone"
    assert subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)]).returncode == 0
    shutil.copy(ROOT / "Makefile", clone / "Makefile")  # the Makefile under test (this tree's, committed or not)
    (clone / "untracked.txt").write_text("not committed\n")
    p = subprocess.run(["make", "--no-print-directory", "gpu-kit"], cwd=clone, capture_output=True, text=True,
                       timeout=120)
    own = [l for l in p.stderr.splitlines() if not re.match(r"make(\[\d+\])?: \*\*\*", l)]  # make[1] under make test
    assert p.returncode == 2 and len(own) == 1 and "uncommitted changes" in own[0], p.stderr
    assert not (clone / "build" / "gpu-kit").exists()
    # the kit of this tree (the fixture's; DIRTY_KIT=1 where it is dirty): its device call, exactly
    p = run(["make", "--no-print-directory", "gpu-kit", "DIRTY_KIT=1"], cwd=ROOT, timeout=1800)
    assert p.returncode == 0, p.stderr[-2000:]
    lines = p.stdout.splitlines()
    call = lines[lines.index("gpu-kit: the call for a lent GPU machine (the device tool's run), from the repository's "
                             "root:") + 1:]
    assert call[0].startswith('  carry:     ["build/gpu-kit"]') and "of the 64 MiB allowed" in call[0], call
    assert call[1] == "  command:   build/gpu-kit/device-run --limit 420" and call[2] == "  timeout_s: 420", call
    assert (ROOT / "build" / "gpu-kit" / "device-run").is_file()
