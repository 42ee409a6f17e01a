#!/usr/bin/env python3
"""The label of a machine, under which its records live: results/<label>/<experiment>/<preset>.jsonl.

    common/machine_label.py            prints this machine's label ($MACHINE when set)
    common/machine_label.py --json     prints this machine's description (label, host, CPU, cores, GPU)

The label is made of what the records' provenance says of a machine: the short host name, the CPU model, the number
of online CPUs, where one is present the GPU model, and the first 6 hex digits of the machine's own random id, e.g.
`vm-amd-epyc-2c-3fa9c1` or `gpu01-intel-xeon-16c-nvidia-h200-07b2e4`. The id is what tells two machines apart when
everything readable from the hardware agrees: VMs cloned from one image share host name, CPU, core count and even
/etc/machine-id. It is made once per machine (uuid4) and kept outside the work tree, in
$HPCGI_STATE_DIR, else $XDG_STATE_HOME/hpcgi, else ~/.local/state/hpcgi (file `machine-id`), so every clone on one
machine shares it and no clone on another machine can; $HPCGI_MACHINE_ID gives it outright (a cluster whose nodes
share no home). The same function derives a label from a record (`from_record`: its provenance and the id the runner
put in its environment), so a machine's records and the machine itself agree.
`MACHINE=name` overrides the label (a cluster's name, say: `MACHINE=maya-like`); it must be a plain folder name.

A machine folder belongs to one machine: its machine.json holds that machine's id. `owner_problem` says why this
machine may not add records to a folder (another machine's, or one whose owner is unknown), and `claim` writes
machine.json into a new folder. Records are never pooled across machines: the reference machine's committed folder
changes only through `make regenerate-reference`, which names it (slurm/regenerate-reference).
Standard library only: it runs on a bare GPU node without the project's virtual environment."""
import hashlib
import json
import os
import re
import shutil
import socket
import subprocess
import sys
import uuid
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # the repository or the kit
from common import harness_io  # noqa: E402  (the one way to open a harness file)

# Names in results/ that are not machines.
RESERVED = {"paper", "tables", "plots", "report"}
_VALID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,79}$")


def slug(text, limit=40):
    """'Intel(R) Xeon(R) CPU E5-2650 v2 @ 2.60GHz' -> 'intel-xeon-e5-2650-v2'."""
    s = str(text or "").lower()
    s = re.sub(r"@.*$", "", s)
    s = re.sub(r"\((r|tm)\)|\b(cpu|processor)\b", " ", s)
    s = re.sub(r"[^a-z0-9]+", "-", s).strip("-")
    return s[:limit].strip("-")


def make(host, cpu_model, cpus, gpu=None, machine_id=None):
    parts = [slug(str(host).split(".")[0], 24), slug(cpu_model), f"{int(cpus)}c"]
    if gpu:
        parts.append(slug(gpu, 24))
    if machine_id:
        parts.append(str(machine_id)[:6])
    return "-".join(p for p in parts if p)


_ID = re.compile(r"^[0-9a-f]{12,64}$")


class NoIdentity(ValueError):
    """This machine's id can be neither read nor made (a state folder that cannot be written, a damaged id file)."""


def id_file():
    base = os.environ.get("HPCGI_STATE_DIR") or os.path.join(
        os.environ.get("XDG_STATE_HOME") or os.path.join(os.path.expanduser("~"), ".local", "state"), "hpcgi")
    return Path(base) / "machine-id"


def machine_id():
    """This machine's random id: $HPCGI_MACHINE_ID, else the id file, made on first use (by a link, so two first
    uses at once agree on one id)."""
    given = os.environ.get("HPCGI_MACHINE_ID", "").strip().lower()
    if given:
        if not _ID.match(given):
            raise NoIdentity(f"HPCGI_MACHINE_ID={given!r} is not 12-64 hex digits")
        return given
    f = id_file()
    try:
        if not f.exists():
            f.parent.mkdir(parents=True, exist_ok=True)
            tmp = f.with_name(f"machine-id.{os.getpid()}.tmp")
            tmp.write_text(uuid.uuid4().hex + "\n")
            try:
                os.link(tmp, f)
            except FileExistsError:
                pass
            finally:
                tmp.unlink()
        mid = (harness_io.read_bytes(f) or b"").decode(errors="replace").strip().lower()
    except harness_io.HarnessFileError as e:
        raise NoIdentity(f"this machine's id file: {e}: remove it and run again") from e
    except OSError as e:
        raise NoIdentity(f"cannot keep this machine's id in {f} ({e.strerror}): set HPCGI_STATE_DIR=DIR "
                         f"(a folder of this machine's) or HPCGI_MACHINE_ID") from e
    if not _ID.match(mid):
        raise NoIdentity(f"{f} holds no machine id (12-64 hex digits): remove it and run again")
    return mid


def check(label):
    """The label if it can name a folder of results/, else ValueError with the reason."""
    if not _VALID.match(label or "") or label in RESERVED:
        raise ValueError(f"MACHINE={label!r} is not a usable machine label: letters, digits, '.', '_' and '-' only "
                         f"(at most 80, not starting with '.' or '-'), and none of {', '.join(sorted(RESERVED))}")
    return label


def cpu_model():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name") and ":" in line:
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown"


def gpu_model():
    """The first GPU's name from nvidia-smi, or None where there is none (or no driver answers)."""
    smi = shutil.which("nvidia-smi")
    if not smi:
        return None
    try:
        out = subprocess.run([smi, "--query-gpu=name", "--format=csv,noheader"], capture_output=True, text=True,
                             timeout=20)
    except (OSError, subprocess.TimeoutExpired):
        return None
    names = [l.strip() for l in out.stdout.splitlines() if l.strip()] if out.returncode == 0 else []
    return names[0] if names else None


def caches():
    """{"l2": "1024K", "l3": "32768K", ...} of the first CPU, as /sys says them (sizes differ between VMs of one CPU
    model, and the claims that depend on a cache differ with them)."""
    out = {}
    base = Path("/sys/devices/system/cpu/cpu0/cache")
    for idx in sorted(base.glob("index*")) if base.is_dir() else []:
        try:
            level, kind = (idx / "level").read_text().strip(), (idx / "type").read_text().strip()
            if kind != "Instruction":
                out[f"l{level}" + ("d" if kind == "Data" else "")] = (idx / "size").read_text().strip()
        except OSError:
            continue
    return out


def describe():
    """This machine: its label (MACHINE when set) and what the label is made of."""
    host = socket.gethostname()
    d = {"host": host, "cpu_model": cpu_model(), "cpus_online": os.sysconf("SC_NPROCESSORS_ONLN"), "gpu": gpu_model(),
         "machine_id": machine_id(), "caches": caches()}
    d["derived_label"] = make(d["host"], d["cpu_model"], d["cpus_online"], d["gpu"], d["machine_id"])
    given = os.environ.get("MACHINE", "").strip()
    d["label"] = check(given) if given else d["derived_label"]
    return d


def this_machine():
    return describe()["label"]


def from_record(rec):
    """The label a record belongs to: the one the runner ran it under (HPCGI_MACHINE: MACHINE=name where given), else
    the one its provenance derives (host, CPU, cores, GPU and the machine's id)."""
    p = rec.get("provenance", {})
    given = (p.get("env") or {}).get("HPCGI_MACHINE")
    if given:
        return given
    gpu = (rec.get("backend_info") or {}).get("gpu")
    return make(p.get("host", "unknown"), p.get("cpu_model", "unknown"), p.get("cpus_online", 0), gpu,
                (p.get("env") or {}).get("HPCGI_MACHINE_ID"))


def digest(mid):
    """What a machine.json publishes of a machine's id: its SHA-256, never the id itself (an id that is published can
    be copied into a forged archive or environment; its digest cannot be turned back into it)."""
    return hashlib.sha256(str(mid).strip().lower().encode()).hexdigest()


def read_owner(folder):
    """The machine.json of a machine folder as a dict, {} where there is none; ValueError where it is damaged or no
    regular file (a FIFO is never waited on)."""
    f = Path(folder) / "machine.json"
    try:
        data = harness_io.read_bytes(f)
    except (OSError, harness_io.HarnessFileError) as e:
        raise ValueError(f"{f} is unreadable ({e})") from e
    if data is None:
        return {}
    try:
        d = json.loads(data.decode())
    except (UnicodeDecodeError, ValueError, RecursionError) as e:
        raise ValueError(f"{f} is unreadable ({e})") from e
    if not isinstance(d, dict):
        raise ValueError(f"{f} is no JSON object")
    return d


def owns(d, mid):
    """Whether the machine of id `mid` is the owner a machine.json `d` names: by the digest it publishes, or, in a
    folder claimed before digests (its id published), by that id, case aside."""
    if isinstance(d.get("machine_id_sha256"), str):
        return d["machine_id_sha256"] == digest(mid)
    return isinstance(d.get("machine_id"), str) and d["machine_id"].strip().lower() == str(mid).strip().lower()


def owner_problem(folder, mid):
    """Why the machine of id `mid` may not add records to `folder`, in one sentence; None where it may (the folder
    is its own, or new: no machine.json and no records)."""
    folder = Path(folder)
    if folder.is_symlink() or (folder.exists() and not folder.is_dir()):
        return f"{folder} is no folder (a link or a file)"
    try:
        d = read_owner(folder)
    except ValueError as e:
        return str(e)
    if d and owns(d, mid):
        return None
    if d.get("machine_id") or d.get("machine_id_sha256"):
        return (f"{folder} belongs to another machine (host {d.get('host', '?')!r}; this machine's id is "
                f"{str(mid)[:6]}...)")
    if d or (folder.is_dir() and any(folder.glob("*/*.jsonl"))):
        return f"{folder} holds records of a machine whose id is not known (no machine_id in its machine.json)"
    return None


def claim(folder, label):
    """Makes `folder` this machine's (its machine.json, under `label`) where it is new, atomically: two first
    writers at once, of two machines, leave one machine.json, and the other is then refused by owner_problem. Returns
    owner_problem's answer after the claim (None: the folder is this machine's)."""
    folder = Path(folder)
    mid = machine_id()
    why = owner_problem(folder, mid)
    if why or (folder / "machine.json").exists():
        return why
    folder.mkdir(parents=True, exist_ok=True)
    d = describe()
    d["label"] = label
    d["machine_id_sha256"] = digest(d.pop("machine_id"))
    tmp = folder / f".machine.json.{os.getpid()}"
    try:
        tmp.write_text(json.dumps(d, sort_keys=True) + "\n")
        os.link(tmp, folder / "machine.json")  # fails where another claimed it first: then its owner decides
    except FileExistsError:
        pass
    except OSError as e:
        return f"cannot claim {folder} ({e.strerror})"
    finally:
        tmp.unlink(missing_ok=True)
    return owner_problem(folder, mid)


WAY_OUT = ("leave MACHINE unset (this machine's own folder) or name a new folder with MACHINE=<name>; the "
           "reference machine's folder changes only by 'make regenerate-reference'")


def checked_label(results, write=False):
    """This machine's label after checking that it may add records to results/<label>/ (write=True: and claiming it
    when new, the check made again after the claim); ValueError with one sentence and the way out where it may not."""
    label = this_machine()
    folder = Path(results) / label
    why = claim(folder, label) if write else owner_problem(folder, machine_id())
    if why:
        raise ValueError(f"{why}: {WAY_OUT}")
    return label


USAGE = """usage: common/machine_label.py [--json | --id | --check RESULTS | --claim RESULTS]
  (none)            this machine's label ($MACHINE when set)
  --json            this machine's description: label, host, CPU, cores, GPU, machine_id
  --id              this machine's random id
  --check RESULTS   the label, after checking that this machine may add records to RESULTS/<label>/ (exit 2 if not)
  --claim RESULTS   as --check, and writes RESULTS/<label>/machine.json where the folder is new"""


def main(argv):
    if argv and argv[0] in ("-h", "--help"):
        print(USAGE)
        return 0
    known = {"--json": 1, "--id": 1, "--check": 2, "--claim": 2}
    if argv and (argv[0] not in known or len(argv) != known[argv[0]]) or len(argv) > 2:
        print(USAGE, file=sys.stderr)
        return 2
    try:
        if argv and argv[0] in ("--check", "--claim"):
            print(checked_label(argv[1], write=argv[0] == "--claim"))
            return 0
        d = describe()
    except ValueError as e:
        print(f"machine_label: {e}", file=sys.stderr)
        return 2
    print(json.dumps(d, sort_keys=True) if argv[:1] == ["--json"] else d["machine_id"] if argv[:1] == ["--id"]
          else d["label"])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
