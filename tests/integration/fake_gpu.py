"""A fake GPU node for the kit's tests, where there is no GPU: a copy of the kit whose poisson, radiosity and stream
run the kit's own programs on the CPU (the GPU backends' runs as openmp) and record them as runs of the backend asked
for on "TEST fake GPU"; an nvidia-smi that names that GPU; and an NVML (libnvidia-ml.so.1) whose clocks, temperature
and clock-limiting reasons (FAKE_NVML_REASONS) the test sets. Everything the kit does around the programs (its plan,
rounds, state files, budget, signals, archive, device-run, the import at home and the tables) then runs for real;
the numbers are the CPU's and are never committed: they carry the fake GPU's name, and the tests write them under
their own temporary folders only."""
import os
import shutil
import stat
import subprocess
import textwrap
from pathlib import Path

FAKE_GPU = "TEST fake GPU (tests/integration/fake_gpu.py)"

FAKE_NVML = r"""
#include <stdlib.h>
typedef void* nvmlDevice_t;
static int dev;
int nvmlInit_v2(void) { return 0; }
int nvmlShutdown(void) { return 0; }
int nvmlDeviceGetHandleByIndex_v2(unsigned i, nvmlDevice_t* h) { if (i) return 2; *h = &dev; return 0; }
int nvmlDeviceGetClockInfo(nvmlDevice_t h, int type, unsigned* mhz) { (void)h; *mhz = type == 2 ? 2619 : 1980; return 0; }
int nvmlDeviceGetTemperature(nvmlDevice_t h, int s, unsigned* c) { (void)h; (void)s; *c = 45; return 0; }
int nvmlDeviceGetPowerUsage(nvmlDevice_t h, unsigned* mw) { (void)h; *mw = 310000; return 0; }
int nvmlDeviceGetCurrentClocksEventReasons(nvmlDevice_t h, unsigned long long* r) {
  const char* s = getenv("FAKE_NVML_REASONS");
  (void)h;
  *r = s ? strtoull(s, 0, 0) : 0;
  return 0;
}
"""

FAKE_SMI = f"""#!/bin/sh
# nvidia-smi of the fake GPU node
case "$*" in
  *--query-gpu=name*) echo "{FAKE_GPU}" ;;
  *--query-gpu=*) echo "{FAKE_GPU}, 999.99, 81559 MiB, 1980 MHz, 2619 MHz, 1980 MHz, 2619 MHz, 700.00 W, 00000000:00:00.0, Default" ;;
  *-q*) echo "==============NVSMI LOG=============="; echo "Product Name : {FAKE_GPU}" ;;
  *) echo "fake nvidia-smi: $*" ;;
esac
"""

# The programs' stand-in: the real one (cpu-bin/, beside bin/ so that its $ORIGIN/../lib is the kit's lib/) with
# the GPU backend's run made on openmp, its record then naming the backend asked for and the fake GPU.
WRAPPER = textwrap.dedent('''\
    #!/usr/bin/env python3
    import json, os, subprocess, sys, tempfile
    prog = os.path.basename(sys.argv[0])
    real = os.path.join(os.path.dirname(os.path.abspath(sys.argv[0])), "..", "cpu-bin", prog)
    args, asked, extra = sys.argv[1:], None, {}
    if prog == "stream" and "--device" in args:
        k = args.index("--device")
        asked, args = "gpu", args[:k] + args[k + 2:] + ["--size", "1000000", "--trials", "2"]
    elif "--backend" in args and args[args.index("--backend") + 1] in ("cuda", "cublas", "cublas1", "cublas2", "hybrid"):
        k = args.index("--backend")
        asked, args = args[k + 1], args[:k] + ["--backend", "openmp"] + args[k + 2:]
        for flag, key in (("--fused", "fused"), ("--overlap", "overlap")):
            if flag in args:
                args.remove(flag)
                extra[key] = True
        if "--distribution" in args:
            k = args.index("--distribution")
            extra["distribution"] = float(args[k + 1])
            args = args[:k] + args[k + 2:]
    if asked is None or "--record" not in args:
        os.execv(real, [real] + args)
    k = args.index("--record")
    target, args = args[k + 1], args[:k] + args[k + 2:]
    with tempfile.TemporaryDirectory() as tmp:
        rec_file = os.path.join(tmp, "r.jsonl")
        p = subprocess.run([real] + args + ["--record", rec_file], capture_output=True, text=True)
        sys.stderr.write(p.stderr)
        out = p.stdout
        if os.path.exists(rec_file):
            rec = json.loads(open(rec_file).read().splitlines()[-1])
            if asked != "gpu":
                rec["params"]["backend"] = asked
            rec["params"].update(extra)
            rec.setdefault("backend_info", {})["gpu"] = "''' + FAKE_GPU + '''"
            line = json.dumps(rec)
            with open(target, "a") as f:
                f.write(line + "\\n")
            out = "".join(line + "\\n" if l.startswith("{") else l + "\\n" for l in out.splitlines())
        sys.stdout.write(out)
    sys.exit(p.returncode)
    ''')


def install(kit, tmp):
    """Makes the kit folder `kit` (a copy) a fake GPU node's; returns the environment to run it with."""
    kit, tmp = Path(kit), Path(tmp)
    (kit / "cpu-bin").mkdir()
    for prog in ("poisson", "radiosity", "stream"):
        shutil.move(kit / "bin" / prog, kit / "cpu-bin" / prog)
        (kit / "bin" / prog).write_text(WRAPPER)
        (kit / "bin" / prog).chmod(0o755)
    tools = tmp / "fake-gpu-tools"
    tools.mkdir()
    (tools / "nvidia-smi").write_text(FAKE_SMI)
    (tools / "nvidia-smi").chmod(stat.S_IRWXU)
    (tmp / "nvml.c").write_text(FAKE_NVML)
    cc = subprocess.run(["cc", "-shared", "-fPIC", "-Wl,-soname,libnvidia-ml.so.1", "-o", tools / "libnvidia-ml.so.1",
                         tmp / "nvml.c"], capture_output=True, text=True)
    assert cc.returncode == 0, cc.stderr
    cublas = next((d for d in (os.environ.get("CUDA_HOME", "/usr/local/cuda") + "/lib64", "/usr/local/cuda/lib64")
                   if (Path(d) / "libcublas.so.13").exists()), "")
    return {"PATH": f"{tools}:/usr/bin:/bin", "LD_LIBRARY_PATH": f"{tools}:{cublas}",
            "HOME": str(tmp), "TMPDIR": str(tmp)}
