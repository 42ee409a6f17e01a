"""Which shared libraries a kit binary may take from the node, and ldd's answer parsed.

A kit carries every library its binaries need except these: the C library and its parts, the GCC runtime
(libstdc++, libgcc_s, libgomp: the node has gcc), and CUDA's (cuBLAS and cuSPARSE, with cuSPARSE's nvJitLink, from
the node's toolkit or the nvidia CUDA 13 Python packages, the driver's libcuda). CUDA's runtime is linked statically, so libcudart is not among them."""
import os
import re
import subprocess

# Library names (the part before ".so") a kit binary may resolve outside the kit.
SYSTEM = ("linux-vdso", "linux-gate", "ld-linux-x86-64", "ld-linux-aarch64", "libc", "libm", "libdl", "librt",
          "libpthread", "libutil", "libresolv", "libmvec", "libstdc++", "libgcc_s", "libgomp")
CUDA = ("libcublas", "libcublasLt", "libcusparse", "libnvJitLink", "libcuda", "libnvidia-ml", "libnvidia-ptxjitcompiler")
# The CUDA libraries the binaries link dynamically (the solver's csr product is cuSPARSE's).
CUDA_SONAMES = ("libcublas.so.13", "libcublasLt.so.13", "libcusparse.so.12", "libnvJitLink.so.13")
DEFAULT_TOOLKIT = "/usr/local/cuda"


def stem(name):
    """'libstdc++.so.6' -> 'libstdc++'; '/lib64/ld-linux-x86-64.so.2' -> 'ld-linux-x86-64'."""
    return re.split(r"\.so(\.|$)", os.path.basename(name))[0]


def allowed_outside(name):
    return stem(name) in SYSTEM + CUDA


def ldd(path, env=None):
    """[(name, resolved path or None)] of every library `path` needs (the closure, as ldd lists it)."""
    with open(path, "rb") as f:
        if f.read(2) == b"#!":  # a script: its interpreter's libraries are the node's
            return []
    out = subprocess.run(["ldd", str(path)], capture_output=True, text=True, env=env, timeout=60)
    if out.returncode != 0:
        raise RuntimeError(f"ldd {path} failed: {(out.stderr or out.stdout).strip()}")
    libs = []
    for line in out.stdout.splitlines():
        line = line.strip()
        m = re.match(r"^(\S+)\s+=>\s+(not found|\S+)", line)
        if m:
            libs.append((m.group(1), None if m.group(2) == "not found" else m.group(2)))
        elif line and not line.startswith("statically linked"):
            libs.append((line.split()[0], line.split()[0]))  # the vdso and the loader: no "=>"
    return libs


def problems(path, kit, env=None):
    """What is wrong with `path`'s libraries in kit `kit`: not found, or resolved outside the kit while not allowed
    there. An empty list when every library resolves inside the kit or is an allowed system or CUDA one."""
    kit = os.path.realpath(kit)
    bad = []
    for name, where in ldd(path, env):
        if where is None:
            bad.append(f"{name} not found")
        elif os.path.realpath(where).startswith(kit + os.sep):
            continue
        elif not allowed_outside(name):
            bad.append(f"{name} => {where} (outside the kit, and not an allowed system or CUDA library)")
    return bad


def candidates(environ):
    """Where the CUDA libraries may lie on a node beyond the loader's own search, in the order looked at: the
    toolkit's lib64 ($CUDA_HOME, then /usr/local/cuda), then the library folders of the nvidia CUDA 13 Python
    packages (nvidia-cublas, nvidia-cusparse, nvidia-nvjitlink) in python3's site folders."""
    seen, out = set(), []

    def add(d, how):
        if d and d not in seen:
            seen.add(d)
            out.append((d, how))

    for home, how in ((environ.get("CUDA_HOME"), "CUDA_HOME"), (DEFAULT_TOOLKIT, DEFAULT_TOOLKIT)):
        if home:
            add(os.path.join(home, "lib64"), f"the CUDA toolkit ({how}/lib64)")
            add(os.path.join(home, "targets", "x86_64-linux", "lib"),
                f"the CUDA toolkit ({how}/targets/x86_64-linux/lib)")
    import site
    import sys
    sites = list(sys.path)
    try:
        sites += site.getsitepackages() + [site.getusersitepackages()]
    except AttributeError:
        pass
    for sp in sites:
        for sub in (("nvidia", "cu13", "lib"), ("nvidia", "cublas", "lib"), ("nvidia", "cusparse", "lib"),
                    ("nvidia", "nvjitlink", "lib")):
            add(os.path.join(sp, *sub), "the nvidia CUDA Python packages (" + os.path.join(sp, *sub) + ")")
    return out


def find(sonames, environ=None):
    """{soname: (folder, how it was found)} of the first candidate folder holding each of `sonames`; a soname
    found nowhere maps to (None, what was searched)."""
    environ = os.environ if environ is None else environ
    cands = candidates(environ)
    searched = "searched " + ", ".join(d for d, _ in cands[:6]) + (" and more" if len(cands) > 6 else "")
    out = {}
    for so in sonames:
        out[so] = next(((d, how) for d, how in cands if os.path.isfile(os.path.join(d, so))), (None, searched))
    return out
