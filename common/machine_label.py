#!/usr/bin/env python3
"""The label of a machine, under which its records live: results/<label>/<experiment>/<preset>.jsonl.

    common/machine_label.py            prints this machine's label ($MACHINE when set)
    common/machine_label.py --json     prints this machine's description (label, host, CPU, cores, GPU)

The label is made of what the records' provenance says of a machine: the short host name, the CPU model, the number
of online CPUs and, where one is present, the GPU model, e.g. `vm-amd-epyc-2c` or `gpu01-intel-xeon-16c-nvidia-h200`.
The same function derives it from a record (`from_record`), so a machine's records and the machine itself agree.
`MACHINE=name` overrides it (a cluster's name, say: `MACHINE=maya-like`); it must be a plain folder name.
Standard library only: it runs on a bare GPU node without the project's virtual environment."""
import json
import os
import re
import shutil
import socket
import subprocess
import sys

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


def make(host, cpu_model, cpus, gpu=None):
    parts = [slug(str(host).split(".")[0], 24), slug(cpu_model), f"{int(cpus)}c"]
    if gpu:
        parts.append(slug(gpu, 24))
    return "-".join(p for p in parts if p)


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


def describe():
    """This machine: its label (MACHINE when set) and what the label is made of."""
    host = socket.gethostname()
    d = {"host": host, "cpu_model": cpu_model(), "cpus_online": os.sysconf("SC_NPROCESSORS_ONLN"), "gpu": gpu_model()}
    d["derived_label"] = make(d["host"], d["cpu_model"], d["cpus_online"], d["gpu"])
    given = os.environ.get("MACHINE", "").strip()
    d["label"] = check(given) if given else d["derived_label"]
    return d


def this_machine():
    return describe()["label"]


def from_record(rec):
    """The label a record's provenance derives (the label its machine had, unless it ran under MACHINE=...)."""
    p = rec.get("provenance", {})
    gpu = (rec.get("backend_info") or {}).get("gpu")
    return make(p.get("host", "unknown"), p.get("cpu_model", "unknown"), p.get("cpus_online", 0), gpu)


def main(argv):
    try:
        d = describe()
    except ValueError as e:
        print(f"machine_label: {e}", file=sys.stderr)
        return 2
    print(json.dumps(d, sort_keys=True) if "--json" in argv else d["label"])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
