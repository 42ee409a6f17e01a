"""Records that belong to one machine (issue 31): two machines whose hardware looks the same get two labels, a
machine folder belongs to the machine named in its machine.json, and nothing but `make regenerate-reference` writes
into another machine's folder (the reference's committed one above all)."""
import hashlib
import json
import re
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

from conftest import ROOT, run

sys.path.insert(0, str(ROOT / "common"))
import machine_label  # noqa: E402

REFERENCE = (ROOT / "results" / "REFERENCE").read_text().strip()
LABEL = [sys.executable, ROOT / "common" / "machine_label.py"]


def machine(tmp_path, name):
    """The environment of a machine of its own (its own id folder), with the same hardware as this one."""
    return {"HPCGI_STATE_DIR": str(tmp_path / f"state-{name}"), "MACHINE": ""}


def test_two_machines_with_the_same_hardware_get_two_labels_each_stable(tmp_path):
    a1, a2, b = (run(LABEL, env=machine(tmp_path, n)).stdout.strip() for n in ("a", "a", "b"))
    assert a1 == a2 and a1 != b
    # the label is the hardware's, then the machine's own id
    hw = machine_label.make(*(machine_label.describe()[k] for k in ("host", "cpu_model", "cpus_online", "gpu")))
    assert a1.startswith(hw + "-") and b.startswith(hw + "-")
    ida = run(LABEL + ["--id"], env=machine(tmp_path, "a")).stdout.strip()
    assert a1.endswith(ida[:6]) and len(ida) == 32
    # a cluster whose nodes share no home gives the id outright; a bad one is refused in one line
    assert run(LABEL + ["--id"], env={"HPCGI_MACHINE_ID": "0123456789abcdef"}).stdout.strip() == "0123456789abcdef"
    p = run(LABEL, env={"HPCGI_MACHINE_ID": "not-hex"})
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1
    # a state folder that cannot be made is one line, not a traceback
    blocker = tmp_path / "file"
    blocker.write_text("x")
    p = run(LABEL, env={"HPCGI_STATE_DIR": str(blocker / "sub"), "MACHINE": ""})
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1 and "HPCGI_STATE_DIR" in p.stderr


def lines(path):
    return path.read_text().splitlines() if path.exists() else []


def test_another_machines_folder_is_refused_in_one_line_and_left_as_it_was(tmp_path):
    res = tmp_path / "results"
    base = {"RESULTS": str(res), "FF_DIR": str(tmp_path / "ff"), "PRESET": "ci", "REPEAT": "1", "MACHINE": "lab"}
    a = run([ROOT / "slurm" / "run-case", "formfactors", "0"], env={**base, **machine(tmp_path, "a"), "MACHINE": "lab"})
    assert a.returncode == 0, a.stderr
    owner = json.loads((res / "lab" / "machine.json").read_text())
    mid = run(LABEL + ["--id"], env=machine(tmp_path, "a")).stdout.strip()
    # machine.json publishes the digest of the id, never the id (issue 48: a published id can be copied)
    assert owner["machine_id_sha256"] == hashlib.sha256(mid.encode()).hexdigest() and "machine_id" not in owner
    # a copy of the reference's committed folder: its machine.json and one records file
    ref = res / REFERENCE
    (ref / "table41").mkdir(parents=True)
    shutil.copy(ROOT / "results" / REFERENCE / "machine.json", ref / "machine.json")
    shutil.copy(ROOT / "results" / REFERENCE / "table41" / "quick.jsonl", ref / "table41" / "ci.jsonl")
    before = {f: f.read_bytes() for f in res.rglob("*") if f.is_file()}
    b = {**base, **machine(tmp_path, "b")}
    for label in ("lab", REFERENCE):
        for cmd in ([ROOT / "slurm" / "run-case", "table41", "0"], [ROOT / "slurm" / "run-local", "table41"],
                    [ROOT / "slurm" / "submit", "table41"], ["make", "-s", "reproduce", "EXPERIMENTS=table41"],
                    ["make", "-s", "bench", "BENCH=bench-stream"]):
            p = run(cmd, env={**b, "MACHINE": label}, cwd=ROOT, timeout=120)
            # one line (make adds its own "make: *** [...] Error 2" after it)
            err = [l for l in p.stderr.strip().splitlines() if not re.match(r"make(\[\d+\])?: \*\*\*", l)]
            assert p.returncode == 2 and len(err) == 1 and "MACHINE" in err[0], (cmd, label, p.stdout, p.stderr)
            assert label in err[0] and "regenerate-reference" in err[0]
    assert {f: f.read_bytes() for f in res.rglob("*") if f.is_file()} == before
    # the owner itself goes on writing there
    a = run([ROOT / "slurm" / "run-case", "formfactors", "0"], env={**base, **machine(tmp_path, "a"), "MACHINE": "lab", "REPEAT": "2"})
    assert a.returncode == 0 and len(lines(res / "lab" / "formfactors" / "ci.jsonl")) == 2, a.stderr


def test_a_newcomer_on_the_reference_hardware_writes_a_folder_of_its_own(tmp_path):
    """git clone, then make reproduce with no MACHINE=, on a machine that has run nothing (a new id): every case of
    its own, its records in its own folder, the reference's results/ and report/ untouched."""
    clone = tmp_path / "clone"
    subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
    # this build, copied after the checkout and given one time, so that make finds every target up to date
    now = time.time()
    for d in ("build", "bin"):
        shutil.copytree(ROOT / d, clone / d, symlinks=True, copy_function=shutil.copy,
                        ignore=shutil.ignore_patterns("ff", "gpu-kit*", "*.tmp"))
        for f in (clone / d).rglob("*"):
            os.utime(f, (now, now), follow_symlinks=False)
    (clone / ".venv").symlink_to(ROOT / ".venv")
    env = {**machine(tmp_path, "newcomer"), "PRESET": "ci", "REPEAT": "1", "FF_DIR": str(tmp_path / "ff")}
    env.pop("MACHINE")
    p = run(["make", "-s", "reproduce", "EXPERIMENTS=formfactors table42"], env={**env, "MACHINE": ""}, cwd=clone,
            timeout=900)
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    assert "0 already recorded on this machine" in p.stdout.splitlines()[-3:][0] or \
        "0 already recorded on this machine" in p.stdout
    label = run(LABEL, env={**env, "MACHINE": ""}, cwd=clone).stdout.strip()
    assert label != REFERENCE and (clone / "results" / label / "table42" / "ci.jsonl").exists()
    status = subprocess.run(["git", "status", "--porcelain", "--", f"results/{REFERENCE}", f"report/{REFERENCE}",
                             "results/REFERENCE"], cwd=clone, capture_output=True, text=True).stdout
    assert status == "", status
    recs = [json.loads(l) for l in lines(clone / "results" / label / "table42" / "ci.jsonl")]
    assert recs and all(r["provenance"]["env"]["HPCGI_MACHINE_ID"] == label.rsplit("-", 1)[1][:6] or
                        r["provenance"]["env"]["HPCGI_MACHINE_ID"].startswith(label.rsplit("-", 1)[1]) for r in recs)
    assert all(machine_label.from_record(r) == label for r in recs)
