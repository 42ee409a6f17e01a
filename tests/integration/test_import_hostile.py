"""Hostile archives for make gpu-import (issue 33): another machine's folder, a file name that is a shell command, a
full disk, two imports at once, an archive that unpacks to gigabytes, wrong JSON types, non-finite numbers. Each
asserts the exit status, the one line on stderr and that nothing on disk changed where nothing may."""
import errno
import gzip
import io
import json
import os
import re
import subprocess
import sys
import tarfile
import tempfile

import pytest

from conftest import ROOT, run

sys.path.insert(0, str(ROOT))
from gpukit import archive_check, import_archive  # noqa: E402

LABEL = "test-hostile-node"
NODE = "a1b2c3d4e5f60718"  # the node's machine_id


def record(i, **over):
    rec = {"schema": "hpcgi-record/1", "app": "poisson", "params": {"n": 64 * i, "backend": "cuda"},
           "result": {"converged": True}, "times_s": {"solve": 0.1 * i}, "backend_info": {"gpu": "TEST fake GPU"},
           "provenance": {"git_commit": "test", "git_dirty": False, "compiler": "test", "host": "test", "os": "test",
                          "cpu_model": "test", "cpus_online": 1, "utc": "2026-01-01T00:00:00Z",
                          "env": {"HPCGI_CASE": f"test/{i}", "HPCGI_MACHINE_ID": NODE}}}
    rec.update(over)
    return rec


def lines(*recs):
    return "".join(json.dumps(r) + "\n" for r in recs).encode()


def tar_gz(path, members):
    """A .tar.gz of {name: bytes}."""
    with tarfile.open(path, "w:gz") as t:
        for name, data in members.items():
            info = tarfile.TarInfo(name)
            info.size = len(data)
            t.addfile(info, io.BytesIO(data))
    return path


def machine(mid=NODE, **over):
    return json.dumps({"label": LABEL, "gpu": "TEST fake GPU", "machine_id": mid, **over}).encode()


def archive(path, records=b"", machine_json=None, extra=None):
    members = {f"results/{LABEL}/machine.json": machine() if machine_json is None else machine_json,
               f"results/{LABEL}/table41/paper.jsonl": records or lines(record(1), record(2)), **(extra or {})}
    return tar_gz(path, members)


def importer(path, results, **kw):
    return run([sys.executable, ROOT / "gpukit" / "import_archive.py", path, "--results", results], cwd=ROOT, **kw)


def refused(p, *words):
    err = [l for l in p.stderr.splitlines() if not re.match(r"make(\[\d+\])?: ", l)]
    assert p.returncode == 2 and len(err) == 1, (p.returncode, p.stderr)
    assert all(w in err[0] for w in words), err[0]


def tree(folder):
    return {str(p.relative_to(folder)): p.read_bytes() if p.is_file() else None for p in sorted(folder.rglob("*"))}


def records_in(results):
    return (results / LABEL / "table41" / "paper.jsonl").read_text().splitlines()


def test_an_archive_never_writes_into_another_machines_folder(tmp_path):
    results, dest = tmp_path / "results", tmp_path / "results" / LABEL
    a = archive(tmp_path / "a.tar.gz")
    (dest / "table41").mkdir(parents=True)
    (dest / "table41" / "paper.jsonl").write_bytes(lines(record(7)))
    owners = {"another machine_id": machine("ffffffffffffffff"), "no machine_id (the reference's, say)":
              json.dumps({"label": LABEL, "gpu": "x"}).encode(), "no JSON object": b"[1, 2]"}
    for why, mj in owners.items():
        (dest / "machine.json").write_bytes(mj)
        before = tree(tmp_path)
        refused(importer(a, results), "belongs to another machine", "MACHINE=")
        assert tree(tmp_path) == before, why
    (dest / "machine.json").unlink()  # a folder with no machine.json is no one's to take either
    refused(importer(a, results), "belongs to another machine")
    other = tmp_path / "other"  # results/<label> a link to another machine's folder
    (dest / "machine.json").write_bytes(machine())
    dest.rename(other)
    dest.symlink_to(other)
    refused(importer(a, results), "is no folder")
    dest.unlink()
    other.rename(dest)
    # issue 48: a folder that publishes the archive's own id, as the reference's machine.json published its id, which
    # a forged archive copied: no import made it, so no import writes into it (Table 4.1's N = 256 cell stays)
    before = tree(tmp_path)
    refused(importer(a, results), "no import made it")
    assert tree(tmp_path) == before
    # an earlier import's folder of the same node (the digest of its id, made by gpu-import): its records are added
    from common import machine_label
    (dest / "machine.json").write_text(json.dumps({"label": LABEL, "gpu": "TEST fake GPU", "made_by": "gpu-import",
                                                   "machine_id_sha256": machine_label.digest(NODE)}))
    p = importer(a, results)
    assert p.returncode == 0, p.stderr
    assert len(records_in(results)) == 3
    # the same folder, the archive of another GPU: refused
    (dest / "machine.json").write_text(json.dumps({"label": LABEL, "gpu": "NVIDIA A100", "made_by": "gpu-import",
                                                   "machine_id_sha256": machine_label.digest(NODE)}))
    refused(importer(a, results), "its GPU is")


def test_make_gpu_import_and_plots_take_names_as_arguments_never_as_shell(tmp_path):
    pwned = tmp_path / "pwned"  # named by $PWNED: a file name holds no '/'
    env = {"PWNED": str(pwned)}
    for name in ("a$(touch $PWNED).tar.gz", 'b";touch $PWNED;".tar.gz', "c'`touch $PWNED`'.tar.gz"):
        a = archive(tmp_path / name)
        given = str(a).replace("$", "$$")  # make's own escape: make passes the name on as it is
        p = run(["make", "--no-print-directory", "gpu-import", f"ARCHIVE={given}", f"RESULTS={tmp_path / 'results'}"],
                cwd=ROOT, env=env)
        assert p.returncode == 0, p.stdout + p.stderr
        assert not pwned.exists(), name
    assert len(records_in(tmp_path / "results")) == 2
    p = run(["make", "--no-print-directory", "plots", "MACHINE=x$$(touch $$PWNED)", "PRESET=ci"], cwd=ROOT, env=env)
    assert p.returncode == 2 and "not a usable machine label" in p.stderr and not pwned.exists(), p.stdout + p.stderr


USER_NAMES = ("ARCHIVE", "RESULTS", "MACHINE", "PRESET", "RUNNER", "EXPERIMENTS", "BENCH", "AUDIT_SAMPLE",
              "RRV_SCENES", "KIT", "CUDA_ARCHS", "FUZZ_SECONDS", "FUZZ_BUILD")


def recipes():
    """{target: [recipe lines]} of the Makefile (a continued line joined)."""
    out, target = {}, None
    text = (ROOT / "Makefile").read_text().replace("\\\n", " ")
    for line in text.splitlines():
        if line.startswith("\t") and target:
            out[target].append(line)
        elif re.match(r"^[A-Za-z$][^=:]*:([^=]|$)", line):
            target = line.split(":")[0].strip()
            out[target] = [line]
    return out


def test_no_recipe_puts_a_name_from_the_command_line_into_a_shell_string():
    for target, body in recipes().items():
        for line in body[1:]:
            used = [n for n in USER_NAMES if f"$({n})" in line]
            assert not used, f"{target}: {line.strip()} expands {used} into the shell"


def test_every_target_that_runs_the_venv_installs_it_first():
    rs = recipes()
    for target, body in rs.items():
        text = "\n".join(body[1:])
        if "$(VENV)/bin/python" not in text:
            continue
        prereqs = body[0].split(":", 1)[1].split()
        first = text.index("$(VENV)/bin/python")
        assert "NEEDS_DEPS" in text[:first] or "deps.sh" in text[:first] or any(
            "NEEDS_DEPS" in "\n".join(rs.get(p, [])) for p in prereqs), f"make {target} runs the venv before installing it"


def test_a_full_disk_leaves_every_file_as_it_was(tmp_path, monkeypatch):
    """The write fails half-way (ENOSPC on the second file): nothing changed, no temporary file left."""
    results = tmp_path / "results"
    assert importer(archive(tmp_path / "a.tar.gz"), results).returncode == 0
    more = {f"results/{LABEL}/table43/paper.jsonl": lines(record(9))}
    b = archive(tmp_path / "b.tar.gz", lines(*(record(i) for i in range(1, 30))), extra=more)
    before = tree(tmp_path)
    calls = []
    real = import_archive._write_synced

    def full(path, data):
        calls.append(path)
        if len(calls) == 2:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
        real(path, data)

    monkeypatch.setattr(import_archive, "_write_synced", full)
    with pytest.raises(archive_check.Refused, match="No space left on device.*nothing imported"):
        import_archive.import_archive(b, results)
    assert tree(tmp_path) == before
    monkeypatch.setattr(import_archive, "_write_synced", real)
    import_archive.import_archive(b, results)
    assert len(records_in(results)) == 29


@pytest.mark.skipif(os.geteuid() != 0, reason="mounting a small tmpfs needs root")
def test_a_real_full_disk_leaves_every_file_as_it_was(tmp_path):
    disk = tmp_path / "disk"
    disk.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=192k", "tmpfs", disk], capture_output=True).returncode:
        pytest.skip("mount -t tmpfs is not allowed here")
    try:
        results = disk / "results"
        assert importer(archive(tmp_path / "a.tar.gz"), results).returncode == 0
        filler = disk / "filler"
        with open(filler, "wb", buffering=0) as f:  # the disk full but for 16 kB
            try:
                while True:
                    f.write(b"x" * 4096)
            except OSError:
                pass
        os.truncate(filler, filler.stat().st_size - 16384)
        b = archive(tmp_path / "b.tar.gz", lines(*(record(i, argv=["x" * 600]) for i in range(1, 80))))
        before = tree(results)
        refused(importer(b, results), "No space left on device", "nothing imported")
        assert tree(results) == before
        filler.unlink()
        assert importer(b, results).returncode == 0
        assert len(records_in(results)) == 2 + 79  # b's records differ from a's by their argv
    finally:
        subprocess.run(["umount", disk])


def test_the_same_records_are_added_once_twice_in_an_archive_twice_imported_or_two_at_once(tmp_path):
    one, same = record(1), json.loads(json.dumps(record(1)))
    respelled = "{" + ", ".join(f'"{k}" : {json.dumps(v)}' for k, v in reversed(list(same.items()))) + "}\n"
    a = archive(tmp_path / "a.tar.gz", lines(one, record(2)) + respelled.encode() + lines(record(2)))
    results = tmp_path / "results"
    p = importer(a, results)
    assert p.returncode == 0 and "2 records" in p.stdout and "2 duplicates" in p.stdout, p.stdout + p.stderr
    p = importer(a, results)
    assert p.returncode == 0 and "0 records" in p.stdout, p.stdout
    b = archive(tmp_path / "b.tar.gz", lines(*(record(i) for i in range(1, 40))))
    c = archive(tmp_path / "c.tar.gz", lines(*(record(i) for i in range(20, 60))))
    for trial in range(3):
        res = tmp_path / f"r{trial}"
        procs = [subprocess.Popen([sys.executable, ROOT / "gpukit" / "import_archive.py", x, "--results", res],
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE) for x in (b, c)]
        assert [q.wait(timeout=120) for q in procs] == [0, 0]
        got = records_in(res)
        assert len(got) == len(set(got)) == 59, trial


def gz_zeros(n_mib):
    """A gzip stream of n_mib MiB of zeros, made of one small gzip member repeated (so it is made at once)."""
    return gzip.compress(b"\0" * (1 << 20), 9) * n_mib


def test_a_small_archive_that_unpacks_to_gigabytes_is_refused_in_little_memory(tmp_path):
    """A log member of 3 GiB of zeros (a 3 MB archive), and records over the limit: refused, in well under 300 MB."""
    def bomb(name, mib):
        info = tarfile.TarInfo(name)
        info.size = mib << 20
        head = gzip.compress(info.tobuf(format=tarfile.GNU_FORMAT))
        return head + gz_zeros(mib) + gzip.compress(b"\0" * 1024)

    probe = ("import resource, sys; sys.path.insert(0, sys.argv[1]); from gpukit import import_archive as m; "
             "rc = m.main(sys.argv[2:]); print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss); sys.exit(rc)")
    for name, mib, words in ((f"results/{LABEL}/table41/paper.jsonl", 80, "records are over"),
                             ("logs/progress.log", 3072, "unpacks to more than")):
        path = tmp_path / "bomb.tar.gz"
        path.write_bytes(bomb(name, mib))
        assert path.stat().st_size < 4 << 20
        p = run([sys.executable, "-c", probe, ROOT, path, "--results", tmp_path / "results"], timeout=120)
        refused(p, words)
        assert int(p.stdout.strip()) < 300 * 1024, f"{p.stdout.strip()} kB for {name}"
        assert not (tmp_path / "results").exists()


def test_a_pax_header_or_a_member_count_beyond_reason_is_refused(tmp_path):
    huge = tarfile.TarInfo("logs/x")
    huge.pax_headers = {"comment": "y" * (3 << 20)}
    with tarfile.open(tmp_path / "pax.tar.gz", "w:gz", format=tarfile.PAX_FORMAT) as t:
        t.addfile(huge, io.BytesIO(b""))
    refused(importer(tmp_path / "pax.tar.gz", tmp_path / "results"), "at once")
    many = {f"logs/{i}": b"" for i in range(archive_check.MAX_MEMBERS + 1)}
    refused(importer(tar_gz(tmp_path / "many.tar.gz", many), tmp_path / "results"), "more than")
    assert not (tmp_path / "results").exists()


@pytest.mark.parametrize("what,members", [
    ("machine.json a list", {"machine.json": b"[]"}),
    ("machine.json's gpu a number", {"machine.json": machine(gpu=7)}),
    ("machine.json's machine_id a list", {"machine.json": machine(mid=["a1b2c3d4e5f6"])}),
    ("a record that is a list", {"table41/paper.jsonl": b"[1, 2]\n"}),
    ("backend_info a string", {"table41/paper.jsonl": lines(record(1, backend_info="gpu"))}),
    ("times a string", {"table41/paper.jsonl": lines(record(1, times_s={"solve": "fast"}))}),
    ("a NaN time", {"table41/paper.jsonl": lines(record(1)).replace(b'"solve": 0.1', b'"solve": NaN')}),
    ("an infinite time", {"table41/paper.jsonl": lines(record(1)).replace(b'"solve": 0.1', b'"solve": 1e999')}),
    ("a -Infinity load", {"table41/paper.jsonl": lines(record(1)).replace(b'"cpus_online": 1',
                                                                          b'"cpus_online": 1, "loadavg_1min": -Infinity')}),
    ("nesting 100000 deep", {"table41/paper.jsonl": b"[" * 100000 + b"]" * 100000 + b"\n"}),
    ("an experiment named ..", {"../paper.jsonl": lines(record(1))}),
])
def test_wrong_types_and_non_finite_numbers_are_refused_with_one_line(tmp_path, what, members):
    base = {"machine.json": machine(), "table41/paper.jsonl": lines(record(1))}
    base.update(members)
    a = tar_gz(tmp_path / "a.tar.gz", {f"results/{LABEL}/{k}": v for k, v in base.items()})
    p = importer(a, tmp_path / "results")
    refused(p)
    assert "Traceback" not in p.stderr and not (tmp_path / "results").exists(), what


def test_the_schema_refuses_non_finite_numbers_and_the_readers_their_tokens(tmp_path):
    import jsonschema
    from analysis import records
    from common.record import DEFINITION, loads, validate
    schema = jsonschema.Draft202012Validator(DEFINITION)
    assert schema.is_valid(record(1))
    assert not schema.is_valid(record(1, times_s={"solve": float("inf")}))
    assert not schema.is_valid(record(1, verify={"agreed": True, "max_rel_diff": float("-inf")}))
    assert validate(record(1, result={"rel_residual": float("nan")})) is not None
    for text in ('{"a": NaN}', '{"a": -Infinity}', '{"a": [1e400]}'):
        with pytest.raises(ValueError):
            loads(text)
    f = tmp_path / "ci.jsonl"
    f.write_text(json.dumps(record(1)) + "\n" + json.dumps(record(2)).replace('"solve": 0.2', '"solve": 1e999') + "\n")
    try:
        assert [r["params"]["n"] for r in records.read_jsonl(f)] == [64]
    finally:
        f.unlink()  # (tests/conftest.py checks every record file a test leaves)
        records.INVALID.clear()


def test_every_limit_is_named_in_one_line_for_a_file_that_is_no_archive(tmp_path):
    fifo = tmp_path / "fifo.tar.gz"
    os.mkfifo(fifo)
    refused(importer(fifo, tmp_path / "results"), "no regular file")
    big = tmp_path / "big.tar.gz"
    with open(big, "wb") as f:
        f.truncate(archive_check.MAX_ARCHIVE + 1)
    refused(importer(big, tmp_path / "results"), "MiB")
    with tempfile.NamedTemporaryFile(dir=tmp_path, suffix="\n\x1b[31m.tar.gz") as odd:
        p = importer(odd.name, tmp_path / "results")
        refused(p, "truncated or damaged")
