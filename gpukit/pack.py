#!/usr/bin/env python3
"""Packs the GPU kit (make gpu-kit): the binaries built for the kit, the shared libraries they need that a bare GPU
node lacks, the scenes, the paper and ci presets' case lists, the driver with `run` and `device-run`, the GPU tests and
the analysis package, into one relocatable folder of at most 60 MiB; then prints the call that runs it on a lent GPU
machine (what to carry, the command, its timeout_s).

    gpukit/pack.py --build build/gpu-kit-obj --kit build/gpu-kit --cuda-home /usr/local/cuda --archs 90

Exit status 0 when the kit is whole; 2 with one line when an input is missing, a library does not resolve, or the
kit is over its size limit (the kit is made beside as KIT.part and renamed when whole: no half kit is left)."""
import argparse
import datetime
import hashlib
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from common import backend_facts  # noqa: E402
from gpukit import libs  # noqa: E402

LIMIT = 60 << 20
MARKER = "KIT-MANIFEST.json"
PROGRAMS = ("poisson", "radiosity", "stream")
# lib/stubs/<capability>/<library> (make_stubs): one folder each, so that a node lacking one takes only its stand-in
STUBBED = {"libcublas.so.13": ("cublas", "cuBLAS 13"), "libcusparse.so.12": ("cusparse", "cuSPARSE 12")}
TEST_BINARIES = ("solve_tests",)  # the GPU unit tests (Cuda*), with the rest of the solver suite
OWN_SCENES = ("scene1.xml", "scene2.xml")
RRV_FILES = ("room2.xml", "room3.xml", "teapot.obj", "COPYING")
# The GPU integration tests and what they import, at the same paths as in the repository.
TESTS = ("tests/conftest.py", "tests/integration/test_radiosity_gpu.py")
DRIVER = ("gpukit/__init__.py", "gpukit/libs.py", "gpukit/cases.py", "gpukit/checks.py", "gpukit/plan.py",
          "gpukit/probe.py", "gpukit/node.py", "gpukit/archive.py", "gpukit/driver.py", "gpukit/summary.py",
          "gpukit/gpu_state.py", "gpukit/device_run.py", "gpukit/plan_checks.py", "gpukit/children.py",
          "common/machine_label.py", "common/harness_io.py", "common/backend_facts.py")
PRESETS = ("paper", "ci")  # ci: the tiny cases (gpu-kit/run --preset ci: a smoke run in seconds)


class PackError(Exception):
    pass


def need(path):
    if not Path(path).exists():
        raise PackError(f"{path} not found")
    return Path(path)


def copy(src, dst):
    dst.parent.mkdir(parents=True, exist_ok=True)
    shutil.copy2(need(src), dst)


def write_facts(kit, env):
    """KIT/backends.json: the kit's programs' --list-backends --json (common/backend_facts.py), read by the driver's
    plan and cases on the node without starting the programs there."""
    try:
        facts = {p: backend_facts.from_program(kit / "bin" / p, env) for p in backend_facts.PROGRAMS}
    except backend_facts.FactsError as e:
        raise PackError(str(e)) from e
    (kit / backend_facts.FILE).write_text(json.dumps(facts, indent=1) + "\n")


def pack(a):
    final = Path(a.kit)
    if final.exists() and not (final / MARKER).exists():
        raise PackError(f"{final} exists and is no kit (no {MARKER}): not removing it")
    kit = final.with_name(final.name + ".part")  # made here, renamed when whole: never a half kit
    if kit.exists():
        shutil.rmtree(kit)
    try:
        fill(a, kit)
    except BaseException:
        shutil.rmtree(kit, ignore_errors=True)
        raise
    if final.exists():
        shutil.rmtree(final)
    kit.rename(final)
    total = json.loads((final / MARKER).read_text())["bytes"]
    print(f"gpu-kit: {final} ({total / 2**20:.1f} MiB of {LIMIT >> 20}); on a GPU node: {final.name}/run --dry-run, "
          f"then {final.name}/run")
    print_device_call(final, total)


DEVICE_TRAVELS = 64 << 20  # what travels to a lent machine: the working tree and the carried paths together
DEVICE_TIMEOUT_S = 420  # the call's limit: the kit's 6 minutes and device-run's margin, so a second call still fits


def tree_bytes():
    """Bytes of the working tree that travels to a lent machine: tracked files and untracked ones git does not
    ignore."""
    p = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"], cwd=ROOT,
                       capture_output=True)
    names = {n for n in p.stdout.decode(errors="replace").split("\0") if n}
    return sum((ROOT / n).stat().st_size for n in names if (ROOT / n).is_file() and not (ROOT / n).is_symlink())


def print_device_call(kit, kit_bytes):
    """The exact call for a lent GPU machine: carry the kit (its path in the repository), run device-run with the
    call's limit, import what comes back."""
    try:
        rel = kit.resolve().relative_to(ROOT)
    except ValueError:
        print(f"gpu-kit: {kit} is outside the repository, so it cannot be carried to a lent machine (carry takes "
              f"paths inside the repository): make gpu-kit KIT=build/gpu-kit")
        return
    tree = tree_bytes()
    both = tree + kit_bytes
    print("gpu-kit: the call for a lent GPU machine (the device tool's run), from the repository's root:")
    print(f'  carry:     ["{rel}"]   ({kit_bytes / 2**20:.1f} MiB; with the working tree\'s {tree / 2**20:.1f} MiB '
          f"that travels too: {both / 2**20:.1f} MiB of the {DEVICE_TRAVELS >> 20} MiB allowed"
          f"{'' if both <= DEVICE_TRAVELS else ': TOO MUCH, it will be refused'})")
    print(f"  command:   {rel}/device-run --limit {DEVICE_TIMEOUT_S}")
    print(f"  timeout_s: {DEVICE_TIMEOUT_S}")
    print("  then here: make gpu-import ARCHIVE=<the gpu-kit-*.tar.gz among the files that come back>")


def fill(a, kit):
    build = Path(a.build)
    for p in PROGRAMS:
        copy(build / "bin" / p, kit / "bin" / p)
    for t in TEST_BINARIES:
        copy(build / "tests" / t, kit / "bin" / t)

    # lib/: the libraries ldd resolves outside the allowed ones, found through the build machine's CUDA for cuBLAS.
    env = dict(os.environ, LD_LIBRARY_PATH=os.path.join(a.cuda_home, "lib64"))
    (kit / "lib").mkdir()
    carried = {}
    for b in sorted((kit / "bin").iterdir()):
        for name, where in libs.ldd(b, env):
            if where is None:
                raise PackError(f"{b.name} needs {name}, which ldd does not find here")
            if libs.stem(name) == "libcudart":
                raise PackError(f"{b.name} links CUDA's runtime dynamically ({name}); the kit links it statically")
            if not libs.allowed_outside(name) and name not in carried:
                shutil.copy2(os.path.realpath(where), kit / "lib" / name)
                carried[name] = where
    for b in sorted((kit / "bin").iterdir()):
        bad = libs.problems(b, kit, env)
        if bad:
            raise PackError(f"{b.name}: " + "; ".join(bad))

    make_stubs(kit, env, a.cc)
    for s in OWN_SCENES:
        copy(ROOT / "radiosity" / "scenes" / s, kit / "radiosity" / "scenes" / s)
    rrv = Path(a.rrv_scenes)
    for f in RRV_FILES:  # RRV's scenes are GPL-3.0-or-later: their COPYING travels beside them
        copy(rrv / f, kit / "scenes" / "rrv" / f)
    for preset in PRESETS:
        for f in sorted((ROOT / "slurm" / "cases" / preset).glob("*.txt")):
            copy(f, kit / "cases" / preset / f.name)
    for f in sorted((ROOT / "results" / "paper").glob("*.csv")):
        copy(f, kit / "paper" / f.name)
    for f in DRIVER + TESTS:
        copy(ROOT / f, kit / f)
    write_facts(kit, env)
    for f in sorted((ROOT / "analysis").glob("*.py")):
        copy(f, kit / "analysis" / f.name)
    copy(ROOT / "common" / "record.py", kit / "common" / "record.py")  # the records' writer and reader (analysis/)
    copy(ROOT / "common" / "record.schema.json", kit / "common" / "record.schema.json")  # common/record.py reads it
    # pytest in the kit: no cache folder inside the kit, temporary files under the output folder (run passes
    # --basetemp), the reasons of skips printed.
    (kit / "pytest.ini").write_text("[pytest]\ntestpaths = tests\npythonpath = .\naddopts = -rs -p no:cacheprovider\n")
    for script in ("run", "device-run"):
        copy(ROOT / "gpukit" / script, kit / script)
        os.chmod(kit / script, 0o755)

    git = lambda *args: subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    nvcc = subprocess.run([os.path.join(a.cuda_home, "bin", "nvcc"), "--version"], capture_output=True, text=True)
    files = {}
    for f in sorted(p for p in kit.rglob("*") if p.is_file()):
        files[str(f.relative_to(kit))] = {"bytes": f.stat().st_size,
                                           "sha256": hashlib.sha256(f.read_bytes()).hexdigest()}
    total = sum(v["bytes"] for v in files.values())
    manifest = {
        "kit": "hpcgi gpu-kit/1",
        "git_commit": git("rev-parse", "HEAD"),
        "git_dirty": dirty(),
        "built_utc": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "cuda_archs": a.archs.split(),
        "nvcc": nvcc.stdout.strip().splitlines()[-1] if nvcc.returncode == 0 else "unknown",
        "libraries_carried": {k: v for k, v in sorted(carried.items())},
        "libraries_from_the_node": "glibc, libstdc++, libgcc_s, libgomp, cuBLAS 13 (libcublas.so.13, "
                                   "libcublasLt.so.13), cuSPARSE (libcusparse.so.12, libnvJitLink.so.13), the "
                                   "driver's libcuda",
        "bytes": total,
        "files": files,
    }
    if total > LIMIT:
        raise PackError(f"the kit would be {total / 2**20:.1f} MiB, over its limit of {LIMIT >> 20} MiB")
    (kit / MARKER).write_text(json.dumps(manifest, indent=1) + "\n")
    print(f"gpu-kit: {len(files)} files; libraries carried: {', '.join(carried) or 'none'}")


def dirty():
    """The Makefile's rule for the binaries (GIT_CHANGES): a tracked file that differs from HEAD or an untracked one
    that is not ignored, results/ and report/ aside; outside git, dirty."""
    head = subprocess.run(["git", "rev-parse", "-q", "--verify", "HEAD"], cwd=ROOT, capture_output=True)
    st = subprocess.run(["git", "status", "--porcelain", "--", ".", ":(exclude)results", ":(exclude)report"], cwd=ROOT,
                        capture_output=True, text=True)
    return head.returncode != 0 or st.returncode != 0 or st.stdout.strip() != ""


def dynamic_symbols(path, defined):
    out = subprocess.run(["nm", "-D", "--defined-only" if defined else "--undefined-only", str(path)],
                         capture_output=True, text=True)
    if out.returncode != 0:
        raise PackError(f"nm -D {path} failed: {out.stderr.strip()}")
    return {l.split()[-1].split("@")[0] for l in out.stdout.splitlines() if l.strip()}


def required_versions(path):
    """{library: {symbol version}} that `path` requires (objdump -p's "Version References")."""
    out = subprocess.run(["objdump", "-p", str(path)], capture_output=True, text=True)
    found, lib = {}, None
    for line in out.stdout.split("Version References:")[-1].splitlines():
        if line.strip().startswith("required from "):
            lib = line.strip()[len("required from "):].rstrip(":")
        elif lib and line.strip() and len(line.split()) == 4:
            found.setdefault(lib, set()).add(line.split()[-1])
    return found


def make_stubs(kit, env, cc):
    """lib/stubs/cublas/, lib/stubs/cusparse/: stand-ins for cuBLAS and cuSPARSE, one function for each of their symbols the kit's programs
    import, each returning status 1 (NOT_INITIALIZED; the *String ones a message). gpu-kit/run puts them on the
    path only where the node lacks the real ones, so that the programs start and run every backend that needs
    neither (their steps are skipped by name): with a library absent, the loader would refuse every program."""
    wanted, versions = set(), {}
    for b in sorted((kit / "bin").iterdir()):
        wanted |= dynamic_symbols(b, False)
        for so, names in required_versions(b).items():
            versions.setdefault(so, set()).update(names)
    for so, (cap, lib) in STUBBED.items():
        stubs = kit / "lib" / "stubs" / cap
        stubs.mkdir(parents=True)
        real = next((w for b in sorted((kit / "bin").iterdir()) for n, w in libs.ldd(b, env) if n == so), None)
        if real is None:
            raise PackError(f"no kit program links {so}: the stand-ins would be wrong")
        names = sorted(wanted & dynamic_symbols(real, True))
        src = stubs / f"{so}.c"
        src.write_text(f'static const char why[] = "{lib} is not on this node (a stand-in of the GPU kit, lib/stubs)";\n'
                       + "".join(f"const char* {n}(void) {{ return why; }}\n" if n.endswith("String") else
                                 f"int {n}(void) {{ return 1; }}\n" for n in names))
        script = stubs / f"{so}.map"  # the symbol versions the programs ask of it (cuBLAS 13: "libcublas.so.13")
        script.write_text("".join(f"{v} {{ global: *; }};\n" for v in sorted(versions.get(so, ()))) or "{ global: *; };\n")
        out = subprocess.run([cc, "-shared", "-fPIC", "-O1", f"-Wl,-soname,{so}", f"-Wl,--version-script,{script}",
                              "-o", str(stubs / so), str(src)], capture_output=True, text=True)
        src.unlink()
        script.unlink()
        if out.returncode != 0:
            raise PackError(f"{cc} could not build the stand-in {so}: {out.stderr.strip()[:300]}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", required=True, help="the kit's build folder (binaries in bin/, tests/)")
    ap.add_argument("--kit", required=True, help="the kit folder to make (replaced if it is a kit)")
    ap.add_argument("--cuda-home", required=True, help="the CUDA toolkit the binaries were built with")
    ap.add_argument("--archs", required=True, help="the CUDA architectures built, e.g. '80 90'")
    ap.add_argument("--rrv-scenes", required=True, help="RRV's scenes: room2.xml, room3.xml, teapot.obj, COPYING")
    ap.add_argument("--cc", default="cc", help="the C compiler of the stand-ins for cuBLAS and cuSPARSE (default cc)")
    a = ap.parse_args()
    try:
        pack(a)
    except (PackError, RuntimeError, OSError, subprocess.SubprocessError) as e:
        print(f"gpu-kit: {e}", file=sys.stderr)
        sys.exit(2)


if __name__ == "__main__":
    main()
