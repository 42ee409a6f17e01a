"""The checks of `make gpu-import` (gpukit/import_archive.py), all made before anything is written: a GPU kit's archive
is read to its end within fixed limits (its size, its members, what it unpacks to, what is kept in memory), and
every record it carries is checked against common/record.schema.json. Nothing here writes a byte.

What passes is a Plan: the node's label and machine.json (with its machine_id), and per records file
(<experiment>/<preset>.jsonl) its records in order, each once (a record is the same record when its JSON is, key
order and spacing aside). Anything else is Refused, with one line saying what and where."""
import gzip
import hashlib
import json
import os
import re
import stat
import tarfile
import zlib
from pathlib import PurePosixPath

from analysis.record import loads, validate
from common import machine_label

# The kit's archive is at most 16 MiB (gpukit/driver.py, ARCHIVE_LIMIT, logs cut to fit); four times that is refused
# unread. What it unpacks to is read as a stream and counted, never held: a small archive that unpacks to gigabytes
# is refused when the count passes MAX_UNPACKED. Only machine.json and the records files are kept in memory.
MAX_ARCHIVE = 64 << 20
MAX_UNPACKED = 512 << 20
MAX_MEMBERS = 20000
MAX_KEPT = 64 << 20       # machine.json and the records files together
MAX_LINE = 1 << 20        # one record
MAX_READ = 1 << 20        # one read of the tar reader (a header's long name or pax data included)
# An experiment or preset is a name, never a path (slurm/names.sh holds the same rule for the runner).
NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]{0,63}$")
MACHINE_ID = re.compile(r"^[0-9A-Fa-f]{8,128}$")


class Refused(Exception):
    pass


class Plan:
    def __init__(self, label, machine, machine_id, records):
        self.label, self.machine, self.machine_id, self.records = label, machine, machine_id, records


def key(rec):
    """What makes two records the same record: their JSON, key order and spacing aside (a digest, to keep it small)."""
    return hashlib.sha256(json.dumps(rec, sort_keys=True, separators=(",", ":")).encode()).digest()


class Counted:
    """The unpacked stream of a .tar.gz, as tarfile reads it: every read and seek is counted and held to the
    limits, so neither a long header nor a member claiming terabytes is ever taken into memory."""

    def __init__(self, raw):
        self.gz = gzip.GzipFile(fileobj=raw, mode="rb")

    def read(self, n=-1):
        if n is None or n < 0 or n > MAX_READ:
            raise Refused(f"a header or read of {n} bytes (more than {MAX_READ >> 20} MiB at once)")
        data = self.gz.read(min(n, MAX_UNPACKED + 1 - self.gz.tell()))
        self._room(self.gz.tell())
        return data

    def seek(self, pos, whence=0):
        if whence != 0:
            raise Refused("the tar reader seeks from the end")
        self._room(pos)
        return self.gz.seek(pos)

    def tell(self):
        return self.gz.tell()

    def drain(self):
        """Reads to the end of the gzip stream, so a truncated or corrupt one is found here."""
        while self.read(MAX_READ):
            pass

    @staticmethod
    def _room(end):
        if end > MAX_UNPACKED:
            raise Refused(f"it unpacks to more than {MAX_UNPACKED >> 20} MiB: nothing imported")


def _member_name(m, seen):
    name = PurePosixPath(m.name)
    if name.is_absolute() or ".." in name.parts or not name.parts:
        raise Refused(f"member {m.name!r} points outside the archive's folder")
    text = str(name)
    if text in seen:
        raise Refused(f"member {text!r} is there twice")
    seen.add(text)
    return text


def _wanted(name, m):
    """Whether a member is kept: a regular file under results/ that is a machine.json or a records file."""
    return m.isreg() and name.startswith("results/") and (name.endswith(".jsonl") or name.endswith("/machine.json"))


def _read_member(t, m, kept):
    if m.size + kept > MAX_KEPT:
        raise Refused(f"its records are over {MAX_KEPT >> 20} MiB: nothing imported")
    f, chunks = t.extractfile(m), []
    while True:
        chunk = f.read(MAX_READ)
        if not chunk:
            break
        chunks.append(chunk)
    return b"".join(chunks)


def read_archive(path):
    """{member name: bytes} of the members kept (machine.json and records files), the archive read to its end."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)  # a FIFO never blocks the import
    except OSError as e:
        raise Refused(f"cannot read it ({e.strerror})")
    with os.fdopen(fd, "rb") as raw:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise Refused("it is no regular file")
        if st.st_size > MAX_ARCHIVE:
            raise Refused(f"it is {st.st_size >> 20} MiB, over the {MAX_ARCHIVE >> 20} MiB an archive of the kit can be")
        files, seen, kept = {}, set(), 0
        try:
            stream = Counted(raw)
            with tarfile.open(fileobj=stream, mode="r:") as t:
                while (m := t.next()) is not None:
                    if len(seen) >= MAX_MEMBERS:
                        raise Refused(f"it has more than {MAX_MEMBERS} members")
                    name = _member_name(m, seen)
                    if _wanted(name, m):
                        files[name] = _read_member(t, m, kept)
                        kept += len(files[name])
            stream.drain()
        except (tarfile.TarError, EOFError, zlib.error, OSError, ValueError, OverflowError) as e:
            raise Refused(f"it is truncated or damaged ({type(e).__name__}: {e}): nothing imported")
    return files


def _label(files):
    labels = {PurePosixPath(n).parts[1] for n in files if len(PurePosixPath(n).parts) > 2}
    if len(labels) != 1:
        raise Refused(f"it holds the records of {len(labels)} machines "
                      f"({', '.join(sorted(labels))[:200] or 'none'}); a kit's archive holds one")
    label = labels.pop()
    try:
        return machine_label.check(label)
    except ValueError as e:
        raise Refused(str(e)) from None


def check_machine(data, where):
    """machine.json's content: a JSON object naming a GPU and the node's machine_id. Returns (object, machine_id)."""
    try:
        machine = json.loads(data)
    except (ValueError, RecursionError) as e:
        raise Refused(f"{where} is no JSON ({str(e)[:80]})") from None
    if not isinstance(machine, dict):
        raise Refused(f"{where} is no JSON object (a {type(machine).__name__})")
    gpu, mid = machine.get("gpu"), machine.get("machine_id")
    if not isinstance(gpu, str) or not gpu.strip():
        raise Refused(f"{where} names no GPU: these are no GPU node's records")
    if not isinstance(mid, str) or not MACHINE_ID.match(mid):
        raise Refused(f"{where} carries no machine_id (hex) telling which machine made it")
    return machine, mid


def _records(name, data):
    """The records of one file, each once, in order: [(key, line)], and how many were duplicates."""
    if data and not data.endswith(b"\n"):
        raise Refused(f"{name} ends in half a record (no final newline)")
    out, seen, dup = [], set(), 0
    for k, raw in enumerate(data.split(b"\n")[:-1] if data else [], 1):
        where = f"{name}:{k}"
        if len(raw) > MAX_LINE:
            raise Refused(f"{where} is over {MAX_LINE >> 20} MiB, no record")
        try:
            line = raw.decode("utf-8")
            rec = loads(line)
        except ValueError as e:
            raise Refused(f"{where} is not a whole record ({str(e)[:80]})") from None
        if not isinstance(rec, dict):
            raise Refused(f"{where} is no record (a JSON {type(rec).__name__}, not an object)")
        wrong = validate(rec)
        if wrong:
            raise Refused(f"{where} is no valid hpcgi-record/1 record ({wrong[:160]})")
        gpu = (rec.get("backend_info") or {}).get("gpu")
        if not gpu or not gpu.strip():
            raise Refused(f"{where} carries no GPU (backend_info.gpu): not a GPU run, nothing imported")
        h = key(rec)
        if h in seen:
            dup += 1
            continue
        seen.add(h)
        out.append((h, line))
    return out, dup


def check(files):
    """The Plan of an archive's kept members, or Refused."""
    label = _label(files)
    machine = files.get(f"results/{label}/machine.json")
    if machine is None:
        raise Refused(f"it has no results/{label}/machine.json (the GPU node's description)")
    _, mid = check_machine(machine, f"results/{label}/machine.json")
    records, dup = {}, 0
    for name, data in sorted(files.items()):
        p = PurePosixPath(name)
        if p.suffix != ".jsonl":
            continue
        if len(p.parts) != 4 or not NAME.match(p.parts[2]) or not NAME.match(p.stem):
            raise Refused(f"{name[:200]!r} is not results/<label>/<experiment>/<preset>.jsonl (names of letters, "
                          f"digits, '-' and '_')")
        records[f"{p.parts[2]}/{p.name}"], n = _records(name, data)
        dup += n
    if not any(records.values()):
        raise Refused("it holds no records")
    return Plan(label, machine, mid, records), dup
