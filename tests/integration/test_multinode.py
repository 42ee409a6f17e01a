"""Across real nodes (issue 35): slurm/local-cluster --nodes K runs K Slurm nodes on this machine, each its own
network and UTS namespace. MPI ranks on two hosts give the one-process answers (radiosity within 1e-6, Poisson the
same iterations) and every record lists the host of each rank; a node killed in the middle of a job array loses no
case and duplicates none once slurm/missing's indices are resubmitted; stopping the cluster leaves nothing behind.
Records go only into a temporary RESULTS folder."""
import json
import os
import shutil
import subprocess
import time

import pytest

from conftest import BIN, ROOT, run
from mpi_files import radiosities, rel_diff

CLUSTER = ROOT / "slurm" / "local-cluster"
CONF = "/run/hpcgi-cluster/slurm.conf"
SENV = {"SLURM_CONF": CONF}


def why_not():
    """None where a namespaced cluster can run here, else why not (the skip says it)."""
    if os.geteuid() != 0:
        return "network namespaces need root"
    for tool in ("ip", "unshare", "nsenter", "slurmctld", "slurmd", "sbatch", "mpirun"):
        if not shutil.which(tool):
            return f"no {tool} here (make deps)"
    if subprocess.run(["unshare", "--net", "--uts", "true"], capture_output=True).returncode != 0:
        return "network and UTS namespaces are not allowed here (unshare --net --uts fails)"
    if os.path.exists("/run/hpcgi-cluster"):
        return "a namespaced cluster is already up (/run/hpcgi-cluster): slurm/local-cluster --nodes K stop"
    return None


pytestmark = pytest.mark.skipif(why_not() is not None, reason=f"no namespaced cluster: {why_not()}")


def cluster(k):
    """Starts a K-node cluster; yields; stops it and checks that nothing is left."""
    p = run([CLUSTER, "--nodes", k, "start"], timeout=60)
    assert p.returncode == 0, p.stderr
    try:
        yield
    finally:
        stop = run([CLUSTER, "--nodes", k, "stop"], timeout=60)
        left = run([CLUSTER, "--nodes", k, "check"], timeout=30).stdout.strip()
        assert stop.returncode == 0 and left == "", f"left behind: {left} {stop.stderr}"


def job_states(job):
    """The states of a job's tasks (scontrol keeps ended jobs for MinJobAge, 300 s)."""
    out = run(["scontrol", "-o", "show", "job", job], env=SENV).stdout
    return [w.split("=", 1)[1] for w in out.split() if w.startswith("JobState=")]


def sbatch_wait(*args, env=None, timeout=120):
    """sbatch, then the job's end, asked every 0.2 s (sbatch --wait asks only every few seconds); its states."""
    p = run(["sbatch", "--parsable", *args], env={**SENV, **(env or {})}, cwd=ROOT)
    assert p.returncode == 0, p.stderr + p.stdout
    job = p.stdout.strip().split(";")[0]
    deadline = time.time() + timeout
    while any(s in ("PENDING", "RUNNING", "CONFIGURING", "COMPLETING") for s in job_states(job)):
        assert time.time() < deadline, f"job {job} did not end in {timeout} s"
        time.sleep(0.2)
    return job_states(job)


def last_record(path):
    return json.loads(path.read_text().splitlines()[-1])


def test_mpi_on_two_hosts_gives_the_one_process_answers(tmp_path):
    gen = cluster(2)
    next(gen)
    try:
        out, srun_out = tmp_path / "mpirun", tmp_path / "srun"
        for d, launch in ((out, "mpirun"), (srun_out, "srun")):
            states = sbatch_wait("-N", "2", "--ntasks-per-node=1", f"--output={tmp_path}/{launch}.out",
                                 "slurm/mpi-nodes.sbatch", d, env={"LAUNCH": launch})
            assert states == ["COMPLETED"], (tmp_path / f"{launch}.out").read_text()
    finally:
        next(gen, None)
    scene = ROOT / "radiosity" / "scenes" / "scene1.xml"
    one = tmp_path / "one.xml"
    p = run([BIN / "radiosity", "solve", scene, "--divide", "4", "--ff", out / "ff.ff", "--backend", "openmp",
             "--method", "jacobi", "--precision", "double", "--tol", "1e-8", "--output", one, "--quiet"])
    assert p.returncode == 0, p.stderr
    poisson_one = json.loads(run([BIN / "poisson", "--n", "64", "--backend", "openmp", "--json", "--quiet"]).stdout)
    for d in (out, srun_out):
        for name in ("formfactors", "solve", "poisson"):
            assert last_record(d / f"{name}.jsonl")["mpi"]["hosts"] == ["node1", "node2"], (d, name)
        assert rel_diff(radiosities(d / "solve.xml"), radiosities(one)) < 1e-6
        assert last_record(d / "poisson.jsonl")["result"]["iterations"] == poisson_one["result"]["iterations"]
        assert (d / "ff.ff").read_bytes() == (out / "ff.ff").read_bytes()


def records(results, exp):
    lines = [l for f in results.rglob(f"{exp}/ci.jsonl") for l in f.read_text().splitlines()]
    return [json.loads(l) for l in lines]  # every line whole


def squeue(*args):
    return run(["squeue", "-h", *args], env=SENV).stdout.split()


def test_a_node_killed_mid_array_then_resume_records_every_case_once(tmp_path):
    exp = "accuracy-formfactors"
    lines = (ROOT / "slurm" / "cases" / "ci" / f"{exp}.txt").read_text().splitlines()
    n = sum(1 for l in lines if l.strip() and not l.startswith("#"))  # every case of the list
    env = {**SENV, "RESULTS": str(tmp_path / "results"), "FF_DIR": str(tmp_path / "ff"), "PRESET": "ci",
           "MACHINE": "multinode-test", "REPEAT": "1"}
    gen = cluster(3)
    next(gen)
    try:
        p = run(["sbatch", "--parsable", "--no-requeue", f"--array=0-{n - 1}", "--ntasks=1", "--cpus-per-task=1",
                 f"--output={tmp_path}/%A_%a.out", "slurm/experiment.sbatch", exp], env=env, cwd=ROOT)
        assert p.returncode == 0, p.stderr
        deadline = time.time() + 60
        while True:  # a task running on node2, frozen before its record is written (a quick case may finish first)
            assert time.time() < deadline, "no task on node2 was caught before its record"
            on2 = squeue("-w", "node2", "-t", "R", "-o", "%i")
            if not on2:
                time.sleep(0.1)
                continue
            pids = run(["ip", "netns", "pids", "hpcgi-node2"]).stdout.split()
            run(["kill", "-STOP", *pids])
            done = {l.split('"HPCGI_CASE":')[1].split("/")[2] for f in (tmp_path / "results").rglob(f"{exp}/ci.jsonl")
                    for l in f.read_text().splitlines() if '"HPCGI_CASE":' in l}  # the other nodes go on appending
            if any(t.rsplit("_", 1)[-1] not in done for t in squeue("-w", "node2", "-o", "%i")):
                break
            run(["kill", "-CONT", *pids])
            time.sleep(0.1)
        pids = run(["ip", "netns", "pids", "hpcgi-node2"]).stdout.split()
        run(["kill", "-9", *pids])  # the node dies: its slurmd, the task's run-case and program
        deadline = time.time() + 120
        while squeue("-o", "%i"):
            assert time.time() < deadline, "the array did not end after the node died"
            time.sleep(0.5)
        missing = run([ROOT / "slurm" / "missing", exp], env=env, cwd=ROOT).stdout.strip()
        assert missing, "the killed node's task should be missing"
        sbatch_wait(f"--array={missing}", "--ntasks=1", "--cpus-per-task=1", f"--output={tmp_path}/%A_%a.out", "slurm/experiment.sbatch",
                    exp, env=env)
        assert run([ROOT / "slurm" / "missing", exp], env=env, cwd=ROOT).stdout.strip() == ""
    finally:
        next(gen, None)
    recs = records(tmp_path / "results", exp)
    cases = sorted(r["provenance"]["env"]["HPCGI_CASE"].split("/")[2] for r in recs)
    assert cases == sorted(str(i) for i in range(n)), cases
    assert not list((tmp_path / "ff").glob("*.tmp*")), "a half-written form-factor file remains"
