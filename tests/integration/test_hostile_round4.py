"""Hostile input and faults, round 4 (issue 48): one test per problem found, each of which failed on the main of
that day. The audit never runs what a record says; a forged archive cannot write into another machine's folder (in
test_import_hostile.py); an append is whole or absent and a reader names a bad line and goes on; a full disk is an
error, not exit 0; strings from records are text in the report; a FIFO where a harness file belongs is refused
without a hang; two machines claiming one new folder at once leave it one machine's; OMP_NUM_THREADS is checked like
--threads; the single-node cluster's stop ends only what its start started; a run beside a CPU hog is flagged."""
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import BIN, ROOT, run

sys.path.insert(0, str(ROOT / "common"))
import harness_io  # noqa: E402

SCENE1 = ROOT / "radiosity" / "scenes" / "scene1.xml"


def env(tmp_path, **kw):
    return {"RESULTS": str(tmp_path / "results"), "FF_DIR": str(tmp_path / "ff"), "PRESET": "ci", "REPEAT": "1",
            "MACHINE": "round4", "HPCGI_STATE_DIR": str(tmp_path / "state"), **kw}


def one_line(p):
    own = [l for l in p.stderr.strip().splitlines() if not l.startswith(("make: ***", "make[", "libgomp:"))]
    return len(own) == 1, own


def test_audit_runs_the_case_list_never_a_records_argv(tmp_path):
    """1: a record whose argv says `sh -c 'touch FILE'` (as a forged archive's would) is audited by its case's line
    from today's list; a record whose case is no case of a list is not audited; nothing it carries is run."""
    e = env(tmp_path)
    assert run([ROOT / "slurm" / "run-local", "formfactors"], env=e, timeout=600).returncode == 0
    assert run([ROOT / "slurm" / "run-case", "table42", "0"], env=e).returncode == 0
    pwned = tmp_path / "pwned"
    f = tmp_path / "results" / "round4" / "table42" / "ci.jsonl"
    rec = json.loads(f.read_text().splitlines()[0])
    rec["argv"] = ["sh", "-c", f"touch {pwned}"]
    other = json.loads(json.dumps(rec))
    other["provenance"]["env"]["HPCGI_CASE"] = "ci/table42/0/00000000"  # no such line
    f.write_text(json.dumps(rec) + "\n" + json.dumps(other) + "\n")
    p = run([ROOT / "slurm" / "audit", "ci", "--sample", "10", "--machine", "round4"], env=e, cwd=ROOT, timeout=600)
    assert not pwned.exists(), "the audit ran a record's argv"
    assert p.returncode == 0, p.stdout + p.stderr
    assert "sampled cases reproduce" in p.stdout and "; 1 not audited" in p.stdout, p.stdout
    assert "| ci/table42/0/00000000 | - " in p.stdout.replace("  ", " ").replace("  ", " ") or \
        "not audited" in [l for l in p.stdout.splitlines() if "00000000" in l][0]
    assert "bin/radiosity solve radiosity/scenes/scene1.xml" in p.stdout  # the case's line, not the argv


def test_a_torn_record_is_cut_off_before_the_next_append_and_readers_go_on(tmp_path):
    """3: a write killed half-way leaves half a line; the next append (the programs' and the harness's) cuts it
    off instead of gluing onto it, and says so; a reader names a bad line in the middle and goes on without it."""
    rec = tmp_path / "r.jsonl"
    ff = tmp_path / "s.ff"
    assert run([BIN / "radiosity", "formfactors", SCENE1, "-o", ff, "--hemicube", "16", "--quiet"]).returncode == 0
    rec.write_text('{"schema": "hpcgi-record/1", "app": "radi')  # a killed write
    p = run([BIN / "radiosity", "solve", SCENE1, "--ff", ff, "--steps", "2", "--quiet", "--record", rec])
    assert p.returncode == 0 and "torn line of" in p.stderr, p.stderr
    lines = rec.read_text().splitlines()
    assert len(lines) == 1 and json.loads(lines[0])["app"] == "radiosity"
    with open(rec, "a") as f:
        f.write('{"half": ')
    harness_io.append_line(str(rec), json.dumps({"case": "x", "repeat": 0}))
    assert [json.loads(l).get("case") for l in rec.read_text().splitlines()] == [None, "x"]
    # a bad line in the middle: named with its file and line, the others read
    rec.write_text(lines[0] + "\n{not json\n" + lines[0] + "\n")
    good, bad = harness_io.read_objects(rec)
    assert [n for n, _ in good] == [1, 3] and bad[0][0] == 2
    sys.path.insert(0, str(ROOT))
    from analysis import records
    before = len(records.INVALID)
    assert len(records.read_jsonl(rec)) == 2 and records.INVALID[before][1] == 2


def test_a_full_disk_while_keeping_a_runs_state_is_an_error_with_nothing_half_written(tmp_path):
    """4: the state line of a timed run that cannot be written whole (a full disk) ends the run with exit 1 and one
    line; the file holds no half line; the timing protocol's decision fails too, not silently."""
    disk = tmp_path / "disk"
    disk.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", disk], capture_output=True).returncode:
        pytest.skip("mount -t tmpfs is not allowed here")
    try:
        state = disk / "ci.state.jsonl"
        first = '{"case": "c", "repeat": 0, "pad": "' + "x" * (4096 - 38) + '"}\n'  # a whole page: a line more needs one
        assert len(first) == 4096
        state.write_text(first)
        fd = os.open(disk / "filler", os.O_WRONLY | os.O_CREAT)  # the rest of the disk, as far as it goes
        try:
            while os.write(fd, b"x" * 512):
                pass
        except OSError:
            pass
        finally:
            os.close(fd)
        p = run([sys.executable, ROOT / "common" / "timed_run.py", "--state", state, "--case", "c", "--repeat", "1",
                 "--", "true"])
        assert p.returncode == 1 and "the run's state was not kept" in p.stderr, (p.returncode, p.stderr)
        assert state.read_text() == first
        p = run([sys.executable, ROOT / "common" / "timing_protocol.py", "decide", disk / "r.jsonl", state, "c", "1",
                 "1", "1", "1"])  # round 1 of at most 1: the group's line is due
        assert p.returncode != 0 and "cannot append" in p.stderr, p.stderr
        assert state.read_text() == first
    finally:
        subprocess.run(["umount", disk])


def test_strings_from_records_and_presets_are_text_in_the_report(tmp_path):
    """5: a schema-valid backend of raw HTML and a bidirectional override reaches the report as text; a preset with
    markup or a path is refused with one line, and MACHINES.md is written only by make machines."""
    res = tmp_path / "results"
    (res / "m1" / "table41").mkdir(parents=True)
    lines = (ROOT / "results" / "vm-amd-epyc-2c" / "table41" / "quick.jsonl").read_text().splitlines()[:4]
    out = []
    for l in lines:
        r = json.loads(l)
        r["params"]["backend"] = "<img src=x onerror=alert(1)>\u202e"
        out.append(json.dumps(r))
    (res / "m1" / "table41" / "quick.jsonl").write_text("\n".join(out) + "\n")
    e = {"RESULTS": str(res), "ANALYSIS_ALL_RECORDS": "1"}
    for cmd in ("tables", "report"):
        p = run([sys.executable, "-m", "analysis", cmd, "quick", "--machine", "m1"], env=e, cwd=ROOT, timeout=300)
        assert p.returncode == 0, p.stderr
    text = "".join(f.read_text() for f in (res / "report").rglob("*.md"))
    text += "".join(f.read_text() for f in (res / "m1" / "tables").glob("*.md"))
    assert "<img" not in text and "\u202e" not in text and "&lt;img" in text and "U+202E" in text
    assert not (res / "report" / "MACHINES.md").exists()
    for preset in ("*", "../../other", "<b>x</b>"):
        p = run([sys.executable, "-m", "analysis", "report", preset, "--machine", "m1"], env=e, cwd=ROOT)
        assert p.returncode == 2 and one_line(p)[0] and "is no preset" in p.stderr, p.stderr


@pytest.mark.parametrize("what", ["machine.json", "machine-id", "state"])
def test_a_fifo_where_a_harness_file_belongs_is_refused_without_a_hang(tmp_path, what):
    """6: machine.json, the machine-id file or a state file made a FIFO: one line, exit 2, within seconds."""
    e = env(tmp_path)
    folder = tmp_path / "results" / "round4"
    folder.mkdir(parents=True)
    if what == "machine.json":
        os.mkfifo(folder / "machine.json")
        cmd = [ROOT / "slurm" / "run-case", "table41", "0"]
    elif what == "machine-id":
        (tmp_path / "state").mkdir()
        os.mkfifo(tmp_path / "state" / "machine-id")
        cmd = [sys.executable, ROOT / "common" / "machine_label.py"]
        e["MACHINE"] = ""
    else:
        os.mkfifo(tmp_path / "st.jsonl")
        cmd = [sys.executable, ROOT / "common" / "timed_run.py", "--state", tmp_path / "st.jsonl", "--case", "c",
               "--repeat", "0", "--", "true"]
    p = run(cmd, env=e, timeout=60)
    assert p.returncode == 2 and one_line(p)[0] and ("FIFO" in p.stderr or "no regular file" in p.stderr), p.stderr


def test_two_machines_claiming_one_new_folder_at_once_leave_it_one_machines(tmp_path):
    """7: run many claims of two machine ids at once on one new MACHINE= folder: exactly one id owns it, every claim
    of the other is refused, and the folder's machine.json is that one owner's."""
    res = tmp_path / "results"
    procs = []
    for k in range(12):
        mid = ("a" if k % 2 else "b") * 16
        procs.append(subprocess.Popen([sys.executable, ROOT / "common" / "machine_label.py", "--claim", res],
                                      env={"PATH": "/usr/bin:/bin", "MACHINE": "shared", "HPCGI_MACHINE_ID": mid},
                                      stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True))
    codes = [(("a" if k % 2 else "b"), p.wait()) for k, p in enumerate(procs)]
    owners = {who for who, c in codes if c == 0}
    assert len(owners) == 1, codes
    assert all(c == 2 for who, c in codes if who not in owners), codes
    sys.path.insert(0, str(ROOT / "common"))
    import machine_label
    d = json.loads((res / "shared" / "machine.json").read_text())
    assert machine_label.owns(d, owners.pop() * 16)
    assert not list((res / "shared").glob(".machine.json.*"))


@pytest.mark.parametrize("value", ["100000", "0", "two", "4,", ""])
def test_omp_num_threads_is_checked_like_threads(value):
    """8: OMP_NUM_THREADS=100000 crashed every program (exit 139 in libgomp); now each refuses it in one line."""
    for cmd in ([BIN / "poisson", "--n", "64"], [BIN / "radiosity", "info", SCENE1], [BIN / "stream", "--size", "4096"]):
        p = run(cmd, env={"OMP_NUM_THREADS": value}, timeout=60)
        assert p.returncode == 2 and "OMP_NUM_THREADS" in p.stderr and one_line(p)[0], (cmd, value, p.stderr)


def test_the_single_node_clusters_stop_ends_only_what_its_start_started(tmp_path):
    """9: `local-cluster stop` used pkill -x on slurmd and munged, ending a multi-node cluster's daemons it had not
    started; now it ends only the pids its start noted (none here), and a process named slurmd lives on."""
    fake = tmp_path / "slurmd"
    shutil.copy("/bin/sleep", fake)
    p = subprocess.Popen([fake, "300"])
    try:
        pids = Path("/run/hpcgi-local-cluster.pids")
        saved = pids.read_bytes() if pids.exists() else None
        try:
            if pids.exists():
                pids.unlink()
            out = run([ROOT / "slurm" / "local-cluster", "stop"])
            assert out.returncode == 0, out.stderr
            time.sleep(0.3)
            assert p.poll() is None, "local-cluster stop killed a slurmd it had not started"
            # a state file naming a pid whose start time is not the noted one (a reused pid): left alone
            pids.write_text(f"{p.pid} 1 slurmd\n")
            assert run([ROOT / "slurm" / "local-cluster", "stop"]).returncode == 0
            time.sleep(0.3)
            assert p.poll() is None
        finally:
            if saved is not None:
                pids.write_bytes(saved)
    finally:
        p.kill()
        p.wait()
    bad = run([ROOT / "slurm" / "local-cluster", "--nodes", "x;y", "stop"])
    assert bad.returncode == 2 and one_line(bad)[0], bad.stderr


def test_a_run_beside_a_cpu_hog_is_flagged_disturbed(tmp_path):
    """The disturbance rule sees what the load average sees: a busy loop per core beside a timed run flags it."""
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(os.cpu_count() or 1)]
    try:
        time.sleep(1)
        state = tmp_path / "st.jsonl"
        p = run([sys.executable, ROOT / "common" / "timed_run.py", "--state", state, "--case", "c", "--repeat", "0",
                 "--", BIN / "poisson", "--n", "256", "--quiet"], timeout=120)
        assert p.returncode == 0, p.stderr
        line = json.loads(state.read_text())
        assert line["disturbed"] is True, line
        assert "runnable" in line["reason"] or "CPU pressure" in line["reason"] or "other processes" in line["reason"]
    finally:
        for h in hogs:
            h.send_signal(signal.SIGKILL)
            h.wait()


def test_frames_with_a_key_given_twice_or_a_nul_in_a_name_are_refused_in_one_line(tmp_path):
    scene = ROOT / "radiosity" / "scenes" / "scene2.xml"  # its lights: light.1, light.2
    frames = tmp_path / "f.json"
    ff = tmp_path / "s.ff"
    assert run([BIN / "radiosity", "formfactors", scene, "-o", ff, "--hemicube", "16", "--quiet"]).returncode == 0
    frames.write_text('{"frames": [{"lights": {"light.2": {"intensity": 1}, "light.2": {"intensity": 5}}}]}')
    p = run([BIN / "radiosity", "relight", scene, "--ff", ff, "--frames", frames, "--quiet"])
    assert p.returncode == 2 and "'light.2' is given twice" in p.stderr and one_line(p)[0], p.stderr
    frames.write_text('{"frames": [{"lights": {"light.2\\u0000x": {"intensity": 1}}}]}')
    p = run([BIN / "radiosity", "relight", scene, "--ff", ff, "--frames", frames, "--quiet"])
    assert p.returncode == 2 and "unknown light 'light.2\\x00x'" in p.stderr and one_line(p)[0], p.stderr


def test_poisson_help_lists_only_what_it_accepts():
    text = run([BIN / "poisson", "--help"]).stdout
    assert "--no-verify" not in text
    assert "--no-verify" in run([BIN / "radiosity", "solve", "--help"]).stdout
