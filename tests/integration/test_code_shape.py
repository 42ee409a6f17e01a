"""The shape of the code (issue 15 for radiosity/app/, issue 36 item 5 for the whole tree): no tracked source file
(C++, CUDA, Python, shell; kernels and tests included) longer than 400 lines, and no function in one longer than 80
lines, as lizard counts a function's length (its first line to its last). Shell functions, which lizard does not
read, are measured the same way: from their `name() {` line to the `}` that closes them at the same indentation.

PENDING names the files that other work is reshaping right now: they are left out until it lands, and the list
cannot rot, since an entry that names no tracked source file fails the test."""
import fnmatch
import re
import shutil
import subprocess
from pathlib import Path

import lizard

ROOT = Path(__file__).resolve().parents[2]
MAX_FILE_LINES = 400
MAX_FUNCTION_LINES = 80

# The files over the limits that issue 36 still has to split (fnmatch globs over repository paths; '*' crosses '/').
PENDING = (
)

# Tracked sources written by a program rather than by hand (none today; the case lists slurm/cases/generate.py
# writes are data, not sources). An entry must name a tracked source file, as PENDING's must.
GENERATED = ()

C_LIKE = {".cpp", ".hpp", ".h", ".cc", ".cu", ".cuh"}
SHELL = {".sh", ".sbatch"}
NOT_SOURCES = ("results/", "report/")


def kind(path):
    """'c', 'python' or 'shell' for a source file (by its suffix, or an extensionless script by its #! line), None
    for anything else."""
    if path.suffix in C_LIKE:
        return "c"
    if path.suffix == ".py":
        return "python"
    if path.suffix in SHELL:
        return "shell"
    if path.suffix == "" and path.is_file():
        with open(path, "rb") as f:
            first = f.readline().decode("utf-8", "replace")
        if first.startswith("#!"):
            return "python" if "python" in first else "shell" if re.search(r"\b(ba)?sh\b", first) else None
    return None


def tracked_sources(root=ROOT):
    """{repository path: kind} of every tracked source file (git ls-files), records and reports left out."""
    names = subprocess.run(["git", "ls-files"], cwd=root, capture_output=True, text=True, check=True).stdout.split()
    out = {}
    for name in names:
        k = kind(root / name) if not name.startswith(NOT_SOURCES) else None
        if k:
            out[name] = k
    return out


def shell_functions(text):
    """(name, first line, length) of every function of a shell script."""
    lines = text.splitlines()
    header = re.compile(r"^(\s*)(?:function\s+)?([A-Za-z_][\w-]*)\s*\(\)\s*\{?\s*(#.*)?$")
    found = []
    for i, line in enumerate(lines):
        m = header.match(line)
        if not m:
            continue
        indent = m.group(1)
        end = next((j for j in range(i + 1, len(lines)) if re.fullmatch(re.escape(indent) + r"\}\s*(#.*)?", lines[j])),
                   len(lines) - 1)
        found.append((m.group(2), i + 1, end - i + 1))
    return found


def functions(path, k):
    """(name, first line, length) of every function of one source file of kind k."""
    text = path.read_text(encoding="utf-8", errors="replace")
    if k == "shell":
        return shell_functions(text)
    # lizard knows a language by the suffix: CUDA is C++ to it, an extensionless script is named by its kind.
    as_name = f"{path.name}.cpp" if k == "c" else f"{path.name}.py"
    return [(fn.name, fn.start_line, fn.length)
            for fn in lizard.analyze_file.analyze_source_code(as_name, text).function_list]


def offenders(root, sources):
    """Every file over MAX_FILE_LINES and every function over MAX_FUNCTION_LINES among sources {path: kind}."""
    bad = []
    for name, k in sorted(sources.items()):
        path = root / name
        n = len(path.read_text(encoding="utf-8", errors="replace").splitlines())
        if n > MAX_FILE_LINES:
            bad.append(f"{name}: {n} lines")
        bad += [f"{name}:{line} {fn} ({length} lines)" for fn, line, length in functions(path, k)
                if length > MAX_FUNCTION_LINES]
    return bad


def matches(name, globs):
    return any(fnmatch.fnmatchcase(name, g) for g in globs)


def stale(globs, sources):
    """The entries of globs that name no source file."""
    return [g for g in globs if not any(fnmatch.fnmatchcase(name, g) for name in sources)]


def checked(sources):
    return {n: k for n, k in sources.items() if not matches(n, PENDING) and n not in GENERATED}


def test_every_pending_and_generated_entry_names_a_tracked_source():
    sources = tracked_sources()
    assert not stale(PENDING, sources), "PENDING entries that name no tracked source file: remove them"
    assert not stale(GENERATED, sources), "GENERATED entries that name no tracked source file: remove them"


def test_the_scan_covers_every_kind_of_source():
    sources = tracked_sources()
    for suffix in (".cpp", ".hpp", ".cu", ".cuh", ".py", ".sh", ".sbatch"):
        assert any(n.endswith(suffix) for n in sources), suffix
    # Extensionless scripts are read by their #! line: slurm/run-case is bash, slurm/audit is Python.
    assert sources.get("slurm/run-case") == "shell" and sources.get("slurm/audit") == "python"
    assert "Makefile" not in sources and not any(n.startswith(NOT_SOURCES) for n in sources)
    assert len(checked(sources)) > 0.6 * len(sources)


def test_no_source_file_over_400_lines_and_no_function_over_80():
    bad = offenders(ROOT, checked(tracked_sources()))
    assert not bad, "split by meaning: " + "; ".join(bad)


def _long_body(name, k, n):
    """The lines of a function of n lines in all (header and closing line included) for file `name` of kind k: a
    CUDA kernel in a .cu or .cuh file."""
    if k == "python":
        return ["def planted():"] + ["    x = 1"] * (n - 2) + ["    return x"]
    if k == "shell":
        return ["planted() {"] + ["  echo x"] * (n - 2) + ["}"]
    if name.endswith((".cu", ".cuh")):
        return ["__global__ void planted(float* x) {"] + ["  x[threadIdx.x] += 1.0f;"] * (n - 2) + ["}"]
    return ["int planted() {"] + ["  int x = 1; (void)x;"] * (n - 2) + ["}"]


def test_a_planted_long_function_or_file_fails(tmp_path):
    """Copies of real sources of each kind (a kernel, a test, a script) are clean; a function of 81 lines planted in
    each copy is found, one of 80 is not; a file of 401 lines is found; a pending glob that names nothing is stale."""
    samples = {"radiosity/solve/gpu/device_kernels.cuh": "c", "bench/stream_gpu.cu": "c",
               "tests/unit/common/test_record.cpp": "c", "slurm/run-local": "shell", "slurm/names.sh": "shell",
               "slurm/audit": "python", "gpukit/checks.py": "python"}
    samples = {n: k for n, k in samples.items() if (ROOT / n).exists()}
    assert len(samples) >= 5, samples
    for name in samples:
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(ROOT / name, tmp_path / name)
    assert not offenders(tmp_path, samples)
    for name, k in samples.items():
        text = (ROOT / name).read_text()
        (tmp_path / name).write_text(text + "\n" + "\n".join(_long_body(name, k, MAX_FUNCTION_LINES)) + "\n")
        assert not offenders(tmp_path, {name: k}), name
        (tmp_path / name).write_text(text + "\n" + "\n".join(_long_body(name, k, MAX_FUNCTION_LINES + 1)) + "\n")
        bad = offenders(tmp_path, {name: k})
        assert len(bad) == 1 and "planted" in bad[0] and f"({MAX_FUNCTION_LINES + 1} lines)" in bad[0], (name, bad)
    long_file = tmp_path / "long.hpp"
    long_file.write_text("// x\n" * (MAX_FILE_LINES + 1))
    assert offenders(tmp_path, {"long.hpp": "c"}) == [f"long.hpp: {MAX_FILE_LINES + 1} lines"]
    assert stale(["radiosity/solve/**", "no/such/folder/**"], {"radiosity/solve/solve.cpp": "c"}) == \
        ["no/such/folder/**"]
    assert kind(tmp_path / "slurm/run-local") == "shell" and kind(tmp_path / "slurm/audit") == "python"
