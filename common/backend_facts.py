"""The programs' facts about their backends, read from the programs rather than restated: `bin/poisson
--list-backends --json` and `bin/radiosity --list-backends --json` (names, GPU or not, built, vectors per iteration,
the default iteration limit). Standard library only: the GPU kit's driver reads it on the node.

In the repository the facts come from ROOT/bin/; in the GPU kit from KIT/backends.json, which gpukit/pack.py writes
from the kit's own binaries (the node's Python need not start them before their libraries are set up)."""
import json
import subprocess
from functools import lru_cache
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent  # the repository, or the kit (common/ sits at the same place in both)
PROGRAMS = ("poisson", "radiosity")
FILE = "backends.json"  # in a kit: {"poisson": ..., "radiosity": ...}, each a program's --list-backends --json


class FactsError(RuntimeError):
    pass


def from_program(path, env=None):
    """One program's --list-backends --json, parsed."""
    try:
        p = subprocess.run([str(path), "--list-backends", "--json"], capture_output=True, text=True, timeout=60,
                           env=env)
    except OSError as e:
        raise FactsError(f"{path}: {e}") from e
    if p.returncode != 0:
        raise FactsError(f"{path} --list-backends --json: exit {p.returncode}: {p.stderr.strip()}")
    return json.loads(p.stdout)


@lru_cache(maxsize=None)
def load(root=ROOT):
    """{"poisson": facts, "radiosity": facts} from root/backends.json where it exists (a kit), else from root/bin/."""
    root = Path(root)
    if (root / FILE).is_file():
        return json.loads((root / FILE).read_text())
    missing = [p for p in PROGRAMS if not (root / "bin" / p).is_file()]
    if missing:
        raise FactsError(f"no {root / FILE} and no {', '.join('bin/' + p for p in missing)} under {root}: build them "
                         f"(make) to read their backends")
    return {p: from_program(root / "bin" / p) for p in PROGRAMS}


def backends(program, root=ROOT):
    return {b["name"]: b for b in load(root)[program]["backends"]}


def gpu_backends(root=ROOT):
    """Every backend of either program that runs on a GPU, by name."""
    return sorted({b["name"] for p in PROGRAMS for b in load(root)[p]["backends"] if b["gpu"]})


def poisson_vectors(backend, variant=None, precision="double", root=ROOT):
    """Vectors of N² one plain CG iteration of bin/poisson streams on `backend` (its default variant in `precision`
    unless `variant` is given)."""
    b = backends("poisson", root)[backend]
    return b["vectors_per_iteration"][variant or b["default_variant"][precision]]


def poisson_default_max_iter(n, root=ROOT):
    """bin/poisson's iteration limit with --tol when --max-iter is not given."""
    d = load(root)["poisson"]["default_max_iter"]
    return max(d["floor"], d["per_n"] * n)
