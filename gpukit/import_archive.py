#!/usr/bin/env python3
"""make gpu-import ARCHIVE=FILE: the records of a GPU kit's archive (gpu-kit/run) into results/<label>/, the label
being the GPU node's own (its results/<label>/machine.json).

    gpukit/import_archive.py ARCHIVE [--results results]

All or nothing, and each record once:
- The whole archive is checked before a byte is written (gpukit/archive_check.py): its size, its members and what
  it unpacks to within fixed limits, read to its end (a truncated or damaged one is refused), one machine's records,
  every record valid against common/record.schema.json and made by the node of its machine.json (HPCGI_MACHINE_ID),
  a GPU run naming the node's GPU (backend_info.gpu; the OpenMP runs beside them name none), the state files' lines
  (the GPU's clocks, temperature and throttle reasons beside each run) JSON objects naming their case and repeat.
- A machine's folder is that machine's only: an import writes only into a new folder or one an earlier import of
  the same node made (its machine.json, written by the import, publishes the digest of the node's id, never the id,
  and names its GPU); any other existing results/<label>/ is refused, the reference machine's above all, whatever id
  the archive carries.
- Imports hold a lock on the results folder, so two at once add each record once; a record already there (the same
  JSON, key order and spacing aside), or twice in the archive, is written once.
- Each file is written whole beside itself and renamed over the old one after every file is on disk (fsync), so a
  full disk leaves every file as it was. An existing machine.json is kept.
Exit status 0 when imported (or nothing new); 2 with one line when refused (nothing written)."""
import argparse
import fcntl
import json
import os
import stat
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from common.record import loads  # noqa: E402
from common import machine_label  # noqa: E402
from gpukit.archive_check import Refused, check, key, read_archive, same_gpu  # noqa: E402


def shown(text):
    """A path as one printable line (a file name may hold a newline or an escape sequence)."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in str(text))


def _lstat(path):
    try:
        return os.lstat(path)
    except FileNotFoundError:
        return None


def check_owner(dest, plan):
    """Refuses dest unless it is new or an earlier import's of the same node; True when it exists. A folder that no
    import made (a machine's own, the reference's above all) is never written by an import, whatever id the archive
    carries: its machine.json may publish an id, which a forged archive could copy. An imported folder's machine.json
    publishes only the digest of the node's id, which no archive can be made to match without the id itself."""
    st = _lstat(dest)
    if st is None:
        return False
    if not stat.S_ISDIR(st.st_mode):
        raise Refused(f"{shown(dest)} is no folder (a link or a file): nothing imported")
    why = None
    try:
        machine = machine_label.read_owner(dest)
        if not machine:
            why = "it has no machine.json"
        elif machine.get("made_by") != "gpu-import":
            why = "no import made it (it is a machine's own folder)"
        elif not machine_label.owns(machine, plan.machine_id):
            why = "its machine.json names another machine (the digest of its id is not the archive node's)"
        elif not same_gpu(machine.get("gpu"), json.loads(plan.machine).get("gpu")):
            why = f"its GPU is {shown(machine.get('gpu'))[:60]!r}, not the archive's"
    except ValueError as e:
        why = str(e)
    if why:
        raise Refused(f"{shown(dest)}/ belongs to another machine ({why}): nothing imported; give the node a label of "
                      f"its own (MACHINE=<label> gpu-kit/run on the node) and import that archive")
    return True


def published(plan):
    """The machine.json an import writes: the node's, with the digest of its id instead of the id, made by gpu-import."""
    machine = json.loads(plan.machine)
    machine["machine_id_sha256"] = machine_label.digest(machine.pop("machine_id"))
    machine["made_by"] = "gpu-import"
    return (json.dumps(machine, indent=1, sort_keys=True) + "\n").encode()


def existing(target):
    """(keys of the records already in a records file, its bytes); refuses one that is no plain file or that ends in
    half a line (an interrupted write of old: a record appended to it would be glued to that half)."""
    st = _lstat(target)
    if st is None:
        return set(), b""
    if not stat.S_ISREG(st.st_mode):
        raise Refused(f"{shown(target)} is no plain file: nothing imported")
    data = target.read_bytes()
    if data and not data.endswith(b"\n"):
        raise Refused(f"{shown(target)} ends in half a line: remove that last line, then import again")
    keys = set()
    for raw in data.splitlines():
        try:
            keys.add(key(loads(raw.decode("utf-8"))))
        except (ValueError, RecursionError):
            pass  # a line that is no record is no record of the archive either
    return keys, data


def changes(plan, dest, dest_exists):
    """The folders to make, the files to write [(path, bytes)], how many records are new, how many were there, how
    many state lines are new (a state file's lines are added as a records file's are: each once)."""
    folders, files, added, kept, states = [dest], [], 0, 0, 0
    for rel, recs in plan.records.items():
        target = dest / rel
        st = _lstat(target.parent)
        if st is not None and not stat.S_ISDIR(st.st_mode):
            raise Refused(f"{shown(target.parent)} is no folder (a link or a file): nothing imported")
        folders.append(target.parent)
        keys, old = existing(target)
        new = [line for h, line in recs if h not in keys]
        if rel.endswith(".state.jsonl"):
            states += len(new)
        else:
            kept += len(recs) - len(new)
            added += len(new)
        if new:
            files.append((target, old + "".join(line + "\n" for line in new).encode()))
    if not dest_exists:
        files.append((dest / "machine.json", published(plan)))
    return folders, files, added, kept, states


def _write_synced(path, data):
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o644)
    try:
        view = memoryview(data)
        while view:
            view = view[os.write(fd, view):]
        os.fsync(fd)
    finally:
        os.close(fd)


def _fsync_dir(path):
    fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def commit(folders, files):
    """Writes every file beside its target, then renames each over its target: on any failure before the renames
    (a full disk) the temporary files and the new folders are removed and nothing has changed."""
    made, temps, target = [], [], None
    try:
        for d in folders:
            if _lstat(d) is None:
                os.mkdir(d)
                made.append(d)
        for target, data in files:
            tmp = target.with_name(f".{target.name}.gpu-import-{os.getpid()}")
            temps.append((tmp, target))
            _write_synced(tmp, data)
    except OSError as e:
        for tmp, _ in temps:
            tmp.unlink(missing_ok=True)
        for d in reversed(made):
            os.rmdir(d)
        raise Refused(f"cannot write {shown(target or e.filename)} ({e.strerror}): nothing imported, nothing "
                      f"changed") from None
    for tmp, target in temps:
        os.replace(tmp, target)
    for d in sorted({t.parent for _, t in temps} | {f.parent for f in made}):
        _fsync_dir(d)


def locked(results):
    """An exclusive lock on the results folder (made if missing), held until the returned descriptor is closed."""
    results.mkdir(parents=True, exist_ok=True)
    fd = os.open(results, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    fcntl.flock(fd, fcntl.LOCK_EX)
    return fd


def import_archive(path, results):
    """Imports one archive; returns the line to print. Refused (nothing written) when it may not be imported."""
    plan, dup = check(read_archive(path))
    results = Path(results)
    dest = results / plan.label
    fd = locked(results)
    try:
        dest_exists = check_owner(dest, plan)
        folders, files, added, kept, states = changes(plan, dest, dest_exists)
        commit(folders, files)
    finally:
        os.close(fd)
    note = f"; {dup} duplicates in the archive written once" if dup else ""
    files = sum(1 for rel in plan.records if not rel.endswith(".state.jsonl"))
    return (f"gpu-import: {added} records into {shown(dest)}/ ({files} files; {kept} already there{note}; "
            f"{states} state lines: the GPU's state beside each run)")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("archive", help="a gpu-kit-<label>.tar.gz made by gpu-kit/run")
    ap.add_argument("--results", default="results", help="the results folder (default results)")
    a = ap.parse_args(argv)
    try:
        print(import_archive(a.archive, a.results))
    except Refused as e:
        print(f"gpu-import: {shown(a.archive)}: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
