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

from common.record import loads, validate
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
    """Whether a member is kept: a regular file under results/ that is a machine.json, a records file or a state
    file (<preset>.state.jsonl)."""
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


def same_gpu(a, b):
    """Whether two names of a GPU name the same model (nvidia-smi's and CUDA's may differ in spacing and vendor)."""
    norm = lambda x: re.sub(r"[^a-z0-9]", "", str(x).lower()).removeprefix("nvidia")
    return bool(norm(a)) and bool(norm(b)) and (norm(a) in norm(b) or norm(b) in norm(a))


def _lines(name, data, what):
    """[(where, line, JSON object)] of one JSON Lines file, each line whole and within the limits."""
    if data and not data.endswith(b"\n"):
        raise Refused(f"{name} ends in half a {what} (no final newline)")
    out = []
    for k, raw in enumerate(data.split(b"\n")[:-1] if data else [], 1):
        where = f"{name}:{k}"
        if len(raw) > MAX_LINE:
            raise Refused(f"{where} is over {MAX_LINE >> 20} MiB, no {what}")
        try:
            line = raw.decode("utf-8")
            obj = loads(line)
        except ValueError as e:
            raise Refused(f"{where} is not a whole {what} ({str(e)[:80]})") from None
        if not isinstance(obj, dict):
            raise Refused(f"{where} is no {what} (a JSON {type(obj).__name__}, not an object)")
        out.append((where, line, obj))
    return out


def _records(name, data, machine):
    """The records of one file, each once, in order: [(key, line)], and how many were duplicates. Every record was
    made by the node (its HPCGI_MACHINE_ID is the machine.json's), and a GPU run names the node's GPU; the CPU runs
    the kit makes beside the GPU's (the OpenMP cells the GPU claims compare with) carry no GPU."""
    out, seen, dup = [], set(), 0
    for where, line, rec in _lines(name, data, "record"):
        wrong = validate(rec)
        if wrong:
            raise Refused(f"{where} is no valid hpcgi-record/1 record ({wrong[:160]})")
        env = (rec.get("provenance") or {}).get("env") or {}
        if str(env.get("HPCGI_MACHINE_ID", "")).lower() != machine["machine_id"].lower():
            raise Refused(f"{where} was not made by the machine of the archive's machine.json (its HPCGI_MACHINE_ID "
                          f"is {str(env.get('HPCGI_MACHINE_ID'))[:16]!r}): nothing imported")
        gpu = (rec.get("backend_info") or {}).get("gpu")
        if gpu is not None and not same_gpu(gpu, machine["gpu"]):
            raise Refused(f"{where} names the GPU {str(gpu)[:60]!r}, not the node's ({str(machine['gpu'])[:60]!r}): "
                          "nothing imported")
        h = key(rec)
        if h in seen:
            dup += 1
            continue
        seen.add(h)
        out.append((h, line))
    return out, dup


STATE_KEYS = {"case": str, "repeat": int}  # a state line's keys that the tables read, with their types


def _states(name, data):
    """The state lines of one file (the GPU's and the node's state beside each run), each once: [(key, line)]."""
    out, seen = [], set()
    for where, line, st in _lines(name, data, "state line"):
        for k, t in STATE_KEYS.items():
            if not isinstance(st.get(k), t) or isinstance(st.get(k), bool):
                raise Refused(f"{where}: a state line's {k!r} must be a {t.__name__}: nothing imported")
        if "disturbed" in st and not isinstance(st["disturbed"], bool):
            raise Refused(f"{where}: a state line's 'disturbed' must be true or false: nothing imported")
        h = key(st)
        if h not in seen:
            seen.add(h)
            out.append((h, line))
    return out


def check(files):
    """The Plan of an archive's kept members, or Refused."""
    label = _label(files)
    machine = files.get(f"results/{label}/machine.json")
    if machine is None:
        raise Refused(f"it has no results/{label}/machine.json (the GPU node's description)")
    described, mid = check_machine(machine, f"results/{label}/machine.json")
    records, dup = {}, 0
    for name, data in sorted(files.items()):
        p = PurePosixPath(name)
        if p.suffix != ".jsonl":
            continue
        stem = p.name[: -len(".state.jsonl")] if p.name.endswith(".state.jsonl") else p.stem
        if len(p.parts) != 4 or not NAME.match(p.parts[2]) or not NAME.match(stem):
            raise Refused(f"{name[:200]!r} is not results/<label>/<experiment>/<preset>.jsonl or .state.jsonl (names "
                          f"of letters, digits, '-' and '_')")
        if p.name.endswith(".state.jsonl"):
            records[f"{p.parts[2]}/{p.name}"] = _states(name, data)
        else:
            records[f"{p.parts[2]}/{p.name}"], n = _records(name, data, described)
            dup += n
    if not any(v for k, v in records.items() if not k.endswith(".state.jsonl")):
        raise Refused("it holds no records")
    return Plan(label, machine, mid, records), dup
