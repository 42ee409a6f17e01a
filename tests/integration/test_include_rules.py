"""The folders of radiosity/solve/ are boundaries (issue 36, item 3): each folder includes only the layers below it.

    storage/   the form-factor matrix in its storages and its file: nothing above it (the mesh, the file format
               of radiosity/formfactor/, common/ and storage/ itself)
    config     config.hpp, choices.hpp, methods/stop_rule.hpp: what a solve is asked and says
    core       system.hpp, layout.hpp: the system and the vector layouts, over storage/
    host/      the host kernel library (linear algebra, dense and sparse products, sweeps, the executor): core and below
    contract   kernels.hpp, what a backend supplies: core and below
    methods/   the methods written once: only the contract and the configuration
    backends   cpu/, gpu/, mpi/: anything of the library; never the application
    driver     solve.hpp/.cpp, backends.hpp, storage_choice, mesh_map: anything of the library
and the application (radiosity/app/, radiosity/relight/) calls solve() or a method, never a backend or the kernels.

OPEN lists the known breaks not yet fixed, each with its reason; an entry that no longer breaks a rule fails the test
too, so that the list only shrinks. test_a_planted_wrong_way_include_is_found plants wrong-way includes in a copy of
the tree and checks that each is found."""
import re
import shutil
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
INCLUDE = re.compile(r'^\s*#\s*include\s+"((?:radiosity|common)/[^"]+)"', re.M)
SOURCES = (".hpp", ".cpp", ".cuh", ".cu", ".h")

CONFIG = {"radiosity/solve/config.hpp", "radiosity/solve/choices.hpp", "radiosity/solve/choices.cpp",
          "radiosity/solve/methods/stop_rule.hpp", "radiosity/solve/methods/stop_rule.cpp"}
CORE = {"radiosity/solve/system.hpp", "radiosity/solve/system.cpp", "radiosity/solve/layout.hpp"}
CONTRACT = {"radiosity/solve/kernels.hpp"}
BASE = ("radiosity/mesh.hpp", "common/", "radiosity/formfactor/")


def layer(path):
    """The layer of a file of radiosity/ (a path relative to the root), or None outside the rules."""
    if path in CONFIG:
        return "config"
    if path in CORE:
        return "core"
    if path in CONTRACT:
        return "contract"
    for folder, name in (("storage", "storage"), ("host", "host"), ("methods", "methods"), ("cpu", "backends"),
                         ("gpu", "backends"), ("mpi", "backends")):
        if path.startswith(f"radiosity/solve/{folder}/"):
            return name
    if path.startswith("radiosity/solve/"):
        return "driver"
    if path.startswith(("radiosity/app/", "radiosity/relight/")):
        return "application"
    return None


# What each layer may include, by the included file's layer (BASE files: always).
MAY_INCLUDE = {
    "storage": {"storage"},
    "config": {"config"},
    "core": {"config", "core", "storage"},
    "host": {"config", "core", "storage", "host"},
    "contract": {"config", "core", "storage", "contract"},
    "methods": {"config", "contract", "methods"},
    "backends": {"config", "core", "storage", "host", "contract", "methods", "backends", "driver"},
    "driver": {"config", "core", "storage", "host", "contract", "methods", "backends", "driver"},
    "application": {"config", "core", "storage", "driver", "methods", "application"},
}

# Known breaks not yet fixed: (file, included file) -> the reason.
OPEN = {}


def includes(root):
    """(file, included file) for every quoted include of radiosity/, paths relative to root."""
    for f in sorted((root / "radiosity").rglob("*")):
        if f.suffix in SOURCES and f.is_file():
            rel = f.relative_to(root).as_posix()
            for inc in INCLUDE.findall(f.read_text(errors="replace")):
                yield rel, inc


def violations(root):
    """The includes that break the rules: (file, included file, why)."""
    out = []
    for src, inc in includes(root):
        have = layer(src)
        if have is None or inc.startswith(BASE):
            continue
        if have != "application" and inc.startswith("radiosity/") and not inc.startswith("radiosity/solve/"):
            if have != "driver" or not inc.startswith("radiosity/mesh"):
                out.append((src, inc, f"the library ({have}) includes {inc}, outside it"))
            continue
        want = layer(inc)
        if want is None:
            continue
        if want not in MAY_INCLUDE[have]:
            out.append((src, inc, f"{have} includes {want}"))
    return out


def test_the_tree_keeps_the_include_rules():
    found = violations(ROOT)
    unexpected = [v for v in found if (v[0], v[1]) not in OPEN]
    assert not unexpected, "wrong-way includes:\n" + "\n".join(f"  {s} -> {i}: {why}" for s, i, why in unexpected)
    still = {(s, i) for s, i, _ in found}
    stale = [k for k in OPEN if k not in still]
    assert not stale, f"OPEN entries that no longer break a rule (remove them): {stale}"


def test_the_rules_see_every_folder():
    layers = {layer(s) for s, _ in includes(ROOT)}
    assert {"storage", "config", "core", "host", "contract", "methods", "backends", "driver",
            "application"} <= layers, layers


def plant(root, rel, include):
    f = root / rel
    f.write_text(f'#include "{include}"\n' + f.read_text())


def test_a_planted_wrong_way_include_is_found(tmp_path):
    shutil.copytree(ROOT / "radiosity", tmp_path / "radiosity",
                    ignore=shutil.ignore_patterns("scenes", "web", "*.json", "*.xml"))
    assert [v for v in violations(tmp_path) if (v[0], v[1]) not in OPEN] == []
    planted = [("radiosity/solve/storage/ff_matrix.hpp", "radiosity/solve/solve.hpp"),     # storage -> driver
               ("radiosity/solve/storage/row_blocks.cpp", "radiosity/solve/host/linalg.hpp"),  # storage -> host
               ("radiosity/solve/methods/methods.hpp", "radiosity/solve/host/exec.hpp"),   # methods -> host
               ("radiosity/solve/methods/bicgstab.cpp", "radiosity/solve/solve.hpp"),      # methods -> driver
               ("radiosity/solve/host/linalg.hpp", "radiosity/solve/methods/methods.hpp"),  # host -> methods
               ("radiosity/solve/system.hpp", "radiosity/solve/kernels.hpp"),              # core -> contract
               ("radiosity/solve/cpu/serial.cpp", "radiosity/app/solve_load.hpp"),          # library -> application
               ("radiosity/app/solve_run.cpp", "radiosity/solve/cpu/cpu_kernels.hpp")]     # application -> backend
    for rel, inc in planted:
        plant(tmp_path, rel, inc)
    found = {(s, i) for s, i, _ in violations(tmp_path)}
    missing = [p for p in planted if p not in found]
    assert not missing, f"planted wrong-way includes not found: {missing}"
