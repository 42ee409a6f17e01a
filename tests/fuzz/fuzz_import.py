#!/usr/bin/env python3
"""The fuzz target of make gpu-import (gpukit/archive_check.py, gpukit/import_archive.py), driven by Hypothesis.

    .venv/bin/python tests/fuzz/fuzz_import.py SECONDS BUILD_DIR

Each input is an archive and a results folder as it may be found: archives built member by member (names inside and
outside the node's folder, machine.json and records valid, respelled, duplicated, of wrong JSON types, non-finite,
deeply nested; links and folders as members; pax headers), or a valid archive's bytes cut, flipped or spliced; the
node's folder absent, the node's own, another machine's, or holding an earlier record. What must hold:
- the import returns its line or raises Refused; any other exception is a finding;
- a refused import changes nothing in the results folder;
- an import leaves only valid records, each once, keeps every record that was there, and a second import of the
  same archive adds nothing and changes nothing.
It runs until SECONDS have passed, prints `stat::number_of_executed_units: N` as libFuzzer does (tests/fuzz/run reads
it), keeps Hypothesis's examples in BUILD_DIR/corpus/import, and on a finding writes the archive to
BUILD_DIR/artifacts/import-<hash>.tar.gz and exits 1."""
import hashlib
import io
import json
import shutil
import sys
import tarfile
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent.parent
sys.path.insert(0, str(ROOT))

from hypothesis import HealthCheck, Phase, given, settings, strategies as st  # noqa: E402
from hypothesis.database import DirectoryBasedExampleDatabase  # noqa: E402

from common.record import loads, validate  # noqa: E402
from gpukit import archive_check, import_archive  # noqa: E402

LABEL = "fuzz-node"
NODE, OTHER = "0123456789abcdef", "fedcba9876543210"


def record(i):
    return {"schema": "hpcgi-record/1", "app": "poisson", "params": {"n": i}, "result": {"converged": True},
            "times_s": {"solve": 0.5}, "backend_info": {"gpu": "FUZZ GPU"},
            "provenance": {"git_commit": "f", "git_dirty": False, "compiler": "c", "host": "h", "os": "o",
                           "cpu_model": "m", "cpus_online": 1, "utc": "2026-01-01T00:00:00Z"}}


json_leaf = st.one_of(st.none(), st.booleans(), st.integers(-2 ** 70, 2 ** 70), st.floats(allow_nan=True),
                      st.text(max_size=8))
json_value = st.recursive(json_leaf, lambda c: st.lists(c, max_size=3) | st.dictionaries(st.text(max_size=6), c,
                                                                                          max_size=3), max_leaves=8)
PATHS = ["schema", "app", "params", "result", "times_s", "backend_info", "provenance", "verify", "argv"]


@st.composite
def a_record(draw):
    """A valid record, or one with a field replaced by any JSON value, as one line of text (respelled or not)."""
    rec = record(draw(st.integers(0, 5)))
    if draw(st.integers(0, 4)) == 0:
        where = draw(st.sampled_from(PATHS))
        if draw(st.booleans()) and isinstance(rec.get(where), dict) and rec[where]:
            rec[where][draw(st.sampled_from(sorted(rec[where])))] = draw(json_value)
        else:
            rec[where] = draw(json_value)
    text = json.dumps(rec, sort_keys=draw(st.booleans()), indent=None, separators=draw(st.sampled_from(
        [(",", ":"), (", ", ": ")])))
    if draw(st.integers(0, 4)):
        return text
    return draw(st.sampled_from([text.replace("0.5", "NaN"), text.replace("0.5", "1e999"), "[" * 3000 + "]" * 3000,
                                 text[: len(text) // 2], json.dumps(record(0)).replace("{", "{ ")]))


@st.composite
def members(draw):
    d = f"results/{LABEL}"
    machine = {"label": LABEL, "gpu": "FUZZ GPU", "machine_id": draw(st.sampled_from([NODE] * 5 + [OTHER]))}
    if draw(st.integers(0, 9)) == 0:
        machine[draw(st.sampled_from(["gpu", "machine_id", "label"]))] = draw(json_value)
    out = {f"{d}/machine.json": json.dumps(machine if draw(st.integers(0, 19)) else draw(json_value)).encode()}
    good = [f"{d}/table41/paper.jsonl", f"{d}/table43/paper.jsonl", "logs/l.log", f"{d}/table41/paper.skipped"]
    bad = [f"{d}/x/../paper.jsonl", f"{d}/paper.jsonl", "results/other-node/t/p.jsonl", f"{d}/a b/p.jsonl",
           "/abs.jsonl", f"{d}/t/p.jsonl/x.jsonl", f"{d}/table41/paper.jsonl"]
    names = st.sampled_from(good * 8 + bad)
    for name in draw(st.lists(names, min_size=1, max_size=4)):
        lines = draw(st.lists(a_record(), min_size=1, max_size=5))
        out[name] = ("\n".join(lines) + draw(st.sampled_from(["\n"] * 8 + ["", "\n\n"]))).encode()
    return out


def tar_bytes(files, kinds):
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w:gz", format=tarfile.PAX_FORMAT) as t:
        for (name, data), kind in zip(files.items(), kinds):
            info = tarfile.TarInfo(name)
            if kind == "link":
                info.type, info.linkname = tarfile.SYMTYPE, "/etc/passwd"
            elif kind == "dir":
                info.type = tarfile.DIRTYPE
            elif kind == "pax":
                info.pax_headers = {"comment": "x" * 3000}
            info.size = len(data) if info.isreg() else 0
            t.addfile(info, io.BytesIO(data) if info.isreg() else None)
    return buf.getvalue()


@st.composite
def archives(draw):
    files = draw(members())
    kinds = draw(st.lists(st.sampled_from(["file"] * 30 + ["link", "dir", "pax"]), min_size=len(files),
                          max_size=len(files)))
    data = tar_bytes(files, kinds)
    how = draw(st.sampled_from(["whole"] * 12 + ["cut", "flip", "splice"]))
    if how == "cut":
        data = data[: draw(st.integers(0, len(data)))]
    elif how == "flip":
        at = draw(st.integers(0, len(data) - 1))
        data = data[:at] + bytes([data[at] ^ (1 << draw(st.integers(0, 7)))]) + data[at + 1:]
    elif how == "splice":
        at = draw(st.integers(0, len(data)))
        data = data[:at] + draw(st.binary(max_size=64)) + data[at:]
    return data


def tree(folder):
    return {str(p.relative_to(folder)): p.read_bytes() if p.is_file() else None
            for p in sorted(folder.rglob("*"))} if folder.exists() else {}


def before(results, state):
    """The node's folder as an import may find it."""
    if state == "absent":
        return
    d = results / LABEL / "table41"
    d.mkdir(parents=True)
    mid = {"own": NODE, "other": OTHER}.get(state)
    (results / LABEL / "machine.json").write_text(json.dumps({"gpu": "g", **({"machine_id": mid} if mid else {})}))
    (d / "paper.jsonl").write_text(json.dumps(record(1)) + "\n")


def check_valid(results):
    for f in (results / LABEL).rglob("*.jsonl"):
        keys = set()
        for line in f.read_text().splitlines():
            rec = loads(line)
            assert validate(rec) is None, (f, line[:200])
            k = archive_check.key(rec)
            assert k not in keys, f"{f}: a record twice"
            keys.add(k)


def one(data, state, counter, artifacts):
    counter[0] += 1
    with tempfile.TemporaryDirectory(prefix="fuzz-import-") as tmp:
        tmp = Path(tmp)
        path, results = tmp / "a.tar.gz", tmp / "results"
        path.write_bytes(data)
        before(results, state)
        old = tree(results)
        try:
            try:
                import_archive.import_archive(path, results)
            except archive_check.Refused:
                assert tree(results) == old, "a refused import changed the results folder"
                return
            counter[1] += 1
            check_valid(results)
            kept = {k: v for k, v in old.items() if k.endswith(".jsonl")}
            now = tree(results)
            assert all(now[k].startswith(v) for k, v in kept.items()), "a record that was there is gone"
            line = import_archive.import_archive(path, results)
            assert " 0 records " in line and tree(results) == now, "a second import changed something"
        except BaseException:
            artifacts.mkdir(parents=True, exist_ok=True)
            (artifacts / f"import-{hashlib.sha256(data).hexdigest()[:12]}.tar.gz").write_bytes(data)
            raise


def main(argv):
    seconds, build = float(argv[0]), Path(argv[1])
    counter, artifacts = [0, 0], build / "artifacts"
    db = DirectoryBasedExampleDatabase(str(build / "corpus" / "import"))
    test = settings(max_examples=100, deadline=None, database=db, suppress_health_check=list(HealthCheck),
                    phases=[Phase.reuse, Phase.generate, Phase.shrink])(
        given(archives(), st.sampled_from(["absent", "own"] * 3 + ["other", "no-id"]))(
            lambda data, state: one(data, state, counter, artifacts)))
    end, status = time.monotonic() + seconds, 0
    try:
        while time.monotonic() < end:
            test()
    except Exception as e:  # Hypothesis has printed the falsifying example
        print(f"fuzz: import: finding: {type(e).__name__}: {str(e)[:300]}", file=sys.stderr)
        status = 1
    print(f"fuzz: import: {counter[1]} of {counter[0]} inputs imported, the others refused")
    print(f"stat::number_of_executed_units: {counter[0]}")
    shutil.rmtree(build / "tmp", ignore_errors=True)
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
