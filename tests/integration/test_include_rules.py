"""The include rules (issues 36 and 51): every folder of radiosity/, poisson/ and common/ is a layer, named by its
folder, and each layer includes only the layers below it. A file's layer is its folder, never its name.

    base        common/ (every layer may include it; it includes only itself), radiosity/mesh.hpp (radiosity/'s)
    scene       radiosity/scene/: RRV's scenes read and written, the mesh
    formfactor  radiosity/formfactor/: the hemicube and its references
    dist        radiosity/dist/: how MPI ranks split rows
    render      radiosity/render/: pictures of a solved mesh
  the solver library, radiosity/solve/:
    storage     storage/: the form-factor matrix in its storages
    config      config/: what a solve is asked and says (the configuration, its choices, the stopping rules)
    core        core/: the system and the vector layouts, over storage/
    host        host/: the host kernel library (linear algebra, dense and sparse products, sweeps, the executor)
    contract    contract/: what a backend supplies (the kernels) and the backends' entry points
    methods     methods/: the methods written once, over the contract
    backends    cpu/, gpu/, mpi/: the backends, each behind the contract; never the driver
    driver      the files of radiosity/solve/ itself: the registry, solve(), the storage choice, the mesh maps
  above it:
    ffile       radiosity/formfactor/file/: the form-factor file, read into storage/'s matrix
    relight     radiosity/relight/: the light basis and the frames, over the driver
    application radiosity/app/ and radiosity/main.cpp: calls the driver or a method, never a backend or the kernels
  and bin/poisson, poisson/ (never radiosity/, as radiosity/ never includes poisson/):
    poisson config    config/: the configuration and its choices, the problem (grid, right-hand side, exact u)
    poisson contract  contract/: the kernels a backend supplies (kernels.hpp) and the backends' entry points
    poisson methods   methods/: CG, MG-PCG and full multigrid written once (cg.hpp), the multigrid cycles (mg.hpp)
    poisson backends  backends/: serial, openmp, mpi, cuda, cublas1, cublas2 and their kernels; never the driver
    poisson driver    the files of poisson/ itself: the program, the registry, the float64 check

OPEN lists the known breaks not yet fixed, each with its reason; an entry that no longer breaks a rule fails the test
too, so that the list only shrinks. test_a_planted_wrong_way_include_is_found plants wrong-way includes in a copy of
the tree and checks that each is found."""
import re
import shutil
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
INCLUDE = re.compile(r'^\s*#\s*include\s+"((?:radiosity|poisson|common)/[^"]+)"', re.M)
TOPS = ("radiosity", "poisson", "common")
SOURCES = (".hpp", ".cpp", ".cuh", ".cu", ".h")

# The layers by folder (a path's longest matching folder decides); radiosity/mesh.hpp is base.
FOLDERS = {
    "common": "common",
    "radiosity/scene": "scene",
    "radiosity/formfactor": "formfactor",
    "radiosity/formfactor/file": "ffile",
    "radiosity/dist": "dist",
    "radiosity/render": "render",
    "radiosity/solve/storage": "storage",
    "radiosity/solve/config": "config",
    "radiosity/solve/core": "core",
    "radiosity/solve/host": "host",
    "radiosity/solve/contract": "contract",
    "radiosity/solve/methods": "methods",
    "radiosity/solve/cpu": "backends",
    "radiosity/solve/gpu": "backends",
    "radiosity/solve/mpi": "backends",
    "radiosity/solve": "driver",
    "radiosity/relight": "relight",
    "radiosity/app": "application",
    "radiosity": "application",  # main.cpp: the program
    "poisson/config": "poisson config",
    "poisson/contract": "poisson contract",
    "poisson/methods": "poisson methods",
    "poisson/backends": "poisson backends",
    "poisson": "poisson driver",
}
SOLVER = ("storage", "config", "core", "host", "contract", "methods", "backends", "driver")

# What each layer may include besides the base, by the included file's layer.
MAY_INCLUDE = {
    "common": set(),
    "scene": {"scene"},
    "formfactor": {"formfactor"},
    "dist": {"dist"},
    "render": {"render"},
    "storage": {"storage"},
    "config": {"config"},
    "core": {"config", "core", "storage"},
    "host": {"config", "core", "storage", "host"},
    "contract": {"config", "core", "storage", "contract"},
    "methods": {"config", "contract", "methods"},
    "backends": {"config", "core", "storage", "host", "contract", "methods", "backends"},
    "driver": set(SOLVER),
    "ffile": {"formfactor", "dist", "storage", "ffile"},
    "relight": {"formfactor", "ffile", "storage", "config", "core", "driver", "relight"},
    "application": {"scene", "formfactor", "ffile", "dist", "render", "storage", "config", "core", "methods",
                    "driver", "relight", "application"},
    "poisson config": {"poisson config"},
    "poisson contract": {"poisson config", "poisson contract"},
    "poisson methods": {"poisson config", "poisson contract", "poisson methods"},
    "poisson backends": {"poisson config", "poisson contract", "poisson methods", "poisson backends"},
    "poisson driver": {"poisson config", "poisson contract", "poisson methods", "poisson backends",
                       "poisson driver"},
}

# Known breaks not yet fixed: (file, included file) -> the reason.
OPEN = {}


def layer(path):
    """The layer of a file of radiosity/, poisson/ or common/ (a path relative to the root): its folder's."""
    if path == "radiosity/mesh.hpp":
        return "base"
    folder = path.rsplit("/", 1)[0]
    while folder:
        if folder in FOLDERS:
            return FOLDERS[folder]
        folder = folder.rsplit("/", 1)[0] if "/" in folder else ""
    return None


def includes(root):
    """(file, included file) for every quoted include of radiosity/, poisson/ and common/, paths relative to root."""
    for top in TOPS:
        for f in sorted((root / top).rglob("*")):
            if f.suffix in SOURCES and f.is_file():
                rel = f.relative_to(root).as_posix()
                for inc in INCLUDE.findall(f.read_text(errors="replace")):
                    yield rel, inc


def violations(root):
    """The includes that break the rules: (file, included file, why)."""
    out = []
    for src, inc in includes(root):
        have, want = layer(src), layer(inc)
        if have is None or want is None:
            out.append((src, inc, f"a file outside the layers ({src if have is None else inc})"))
            continue
        if want == "common" or (want == "base" and have != "common" and not have.startswith("poisson")):
            continue  # common/ under everything, radiosity/mesh.hpp under radiosity/
        if want != have and want not in MAY_INCLUDE[have]:
            out.append((src, inc, f"{have} includes {want}"))
    return out


def test_the_tree_keeps_the_include_rules():
    found = violations(ROOT)
    unexpected = [v for v in found if (v[0], v[1]) not in OPEN]
    assert not unexpected, "wrong-way includes:\n" + "\n".join(f"  {s} -> {i}: {why}" for s, i, why in unexpected)
    still = {(s, i) for s, i, _ in found}
    stale = [k for k in OPEN if k not in still]
    assert not stale, f"OPEN entries that no longer break a rule (remove them): {stale}"


def test_every_folder_is_a_layer():
    sources = [f for top in TOPS for f in (ROOT / top).rglob("*")
               if f.suffix in SOURCES and f.is_file()]
    outside = sorted({f.relative_to(ROOT).as_posix() for f in sources if layer(f.relative_to(ROOT).as_posix()) is None})
    assert not outside, f"files in no layer (name their folder's layer in FOLDERS): {outside}"
    layers = {layer(s) for s, _ in includes(ROOT)}
    assert set(MAY_INCLUDE) <= layers, set(MAY_INCLUDE) - layers


def plant(root, rel, include):
    f = root / rel
    f.write_text(f'#include "{include}"\n' + f.read_text())


def test_a_planted_wrong_way_include_is_found(tmp_path):
    for top in TOPS:
        shutil.copytree(ROOT / top, tmp_path / top, ignore=shutil.ignore_patterns("scenes", "web", "*.json", "*.xml",
                                                                                   "*.py", "__pycache__"))
    assert [v for v in violations(tmp_path) if (v[0], v[1]) not in OPEN] == []
    planted = [("radiosity/solve/storage/ff_matrix.hpp", "radiosity/solve/solve.hpp"),      # storage -> driver
               ("radiosity/solve/storage/row_blocks.cpp", "radiosity/solve/host/linalg.hpp"),  # storage -> host
               ("radiosity/solve/methods/methods.hpp", "radiosity/solve/host/exec.hpp"),    # methods -> host
               ("radiosity/solve/methods/bicgstab.cpp", "radiosity/solve/solve.hpp"),       # methods -> driver
               ("radiosity/solve/host/linalg.hpp", "radiosity/solve/methods/methods.hpp"),  # host -> methods
               ("radiosity/solve/core/system.hpp", "radiosity/solve/contract/kernels.hpp"),  # core -> contract
               ("radiosity/solve/cpu/serial.cpp", "radiosity/solve/solve.hpp"),              # backend -> driver
               ("radiosity/solve/gpu/cuda_aos.cu", "radiosity/solve/storage_choice.hpp"),    # backend -> driver
               ("radiosity/solve/cpu/serial.cpp", "radiosity/app/solve_load.hpp"),           # library -> application
               ("radiosity/app/solve_run.cpp", "radiosity/solve/cpu/cpu_kernels.hpp"),      # application -> backend
               ("radiosity/scene/subdivide.cpp", "radiosity/formfactor/hemicube.hpp"),      # scene -> formfactor
               ("radiosity/formfactor/hemicube.cpp", "radiosity/formfactor/file/file.hpp"),  # formfactor -> ffile
               ("radiosity/relight/frames.cpp", "radiosity/app/commands.hpp"),               # relight -> application
               ("common/files.cpp", "radiosity/mesh.hpp"),                                   # common -> radiosity
               ("poisson/backends/serial.cpp", "poisson/verify.hpp"),                        # backend -> driver
               ("poisson/backends/cuda.cu", "poisson/verify.hpp"),                           # backend -> driver
               ("poisson/methods/cg.hpp", "poisson/backends/cpu_block.hpp"),                # methods -> backend
               ("poisson/contract/kernels.hpp", "poisson/methods/mg.hpp"),                  # contract -> methods
               ("poisson/main.cpp", "radiosity/mesh.hpp"),                                   # poisson -> radiosity
               ("radiosity/app/solve_run.cpp", "poisson/contract/kernels.hpp")]             # radiosity -> poisson
    for rel, inc in planted:
        plant(tmp_path, rel, inc)
    found = {(s, i) for s, i, _ in violations(tmp_path)}
    missing = [p for p in planted if p not in found]
    assert not missing, f"planted wrong-way includes not found: {missing}"
