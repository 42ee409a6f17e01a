"""The run of gpu-kit/run on the node, after its arguments: the probes of the node, said in the first lines, its
machine.json, then the plan's steps (gpukit/driver.py's Driver runs them). Standard library only."""
import json
import shutil
import subprocess
import sys

from gpukit import gpu_state, libs, plan, probe
from gpukit.plan import Outcome

EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_NO_GPU, EXIT_SKIPPED = 0, 1, 2, 3, 6


def go(d, steps, kit):
    """Everything between the output folder's making and the summary. Returns EXIT_NO_GPU where there is no GPU,
    else None (the driver judges the outcomes)."""
    libraries_ok = probe_libraries(d, kit)
    has_driver, line = probe.driver(d.env, kit)
    d.found.append(f"driver: {line}")
    d.say(f"driver: {line}")
    write_machine(d, kit)
    if not libraries_ok:
        return None  # the kit's programs cannot start here: said, and counted as a failure
    state, why = probe_gpu(d.env, kit)
    d.found.append("GPU: " + ("the cuda backend runs" if state is None else why))
    d.say("GPU: " + ("the cuda backend runs (bin/poisson --backend cuda --n 4)" if state is None else why))
    if state == "broken":
        d.outcomes.append(Outcome("GPU probe", "probe", 0, "FAILED", why=why))
    if state is None:
        d.nvml = gpu_state.Nvml.open()
        sample = d.gpu_sample()
        line = (f"GPU state (NVML, sampled before and after every recorded run): {gpu_state.show(sample)}" if d.nvml
                else f"GPU state: not sampled: {gpu_state.Nvml.why}")
        d.found.append(line)
        d.say(line)
        usable, line = probe.sanitizer(probe.sanitizer_path(d.env), kit / "bin" / "poisson", d.env, kit)
        d.found.append(f"compute-sanitizer: {line}")
        d.say(f"compute-sanitizer: {line}")
        if not usable:
            d.missing["sanitizer"] = line
    plan.print_plan(steps, d.budget)
    first = next((s for s in steps if s.group == "formfactors"), None)  # scene 1's: needs no GPU
    if first is not None:
        d.run_step(first)
    if state == "absent":
        print(f"gpu-kit: no GPU: {why} ({'driver: ' + line if not has_driver else 'the driver loads'}); ran only "
              "what needs none (the form factors of scene 1)", file=sys.stderr)
        return EXIT_NO_GPU
    d.run_all([s for s in steps if s is not first])  # the plan's order: the GPU's probe first
    return None


def probe_libraries(d, kit):
    """Sets d.env: the node's environment added to, with the folders of the CUDA libraries the loader does not find
    by itself; the capabilities still missing go to d.missing, with the kit's stand-ins (lib/stubs/<capability>) on the path so
    that the programs start and run what needs none of them. False when a program cannot start at all."""
    d.env = d.child_env()
    binaries = sorted((kit / "bin").iterdir())
    caps, other = probe.missing_libraries(binaries, d.env)
    extra, searched = [], {}
    if caps:
        want = [so for cap in caps for so in probe.CAPABILITY_LIBS[cap]]
        found = libs.find(want, d.env)
        extra = list(dict.fromkeys(folder for folder, _ in found.values() if folder))
        searched = {so: how for so, (folder, how) in found.items() if not folder}
        d.env = d.child_env(extra)
        caps, other = probe.missing_libraries(binaries, d.env)
    where = {}
    try:
        where = {name: path for name, path in probe.resolved(binaries, d.env) if path}
    except (RuntimeError, OSError, subprocess.TimeoutExpired):
        pass
    for cap, sonames in probe.CAPABILITY_LIBS.items():
        if cap in caps:
            how = next((searched[so] for so in sonames if so in searched), None)
            line = caps[cap] + (f" ({how}, and the loader's own search)" if how else " (the loader's own search)")
        else:
            line = f"{probe.CAPABILITY_NAMES[cap]}: " + ", ".join(f"{so} => {where.get(so, '?')}" for so in sonames)
        d.found.append(line)
        d.say(line)
    stubs = [kit / "lib" / "stubs" / cap for cap in caps]
    if caps and all(s.is_dir() for s in stubs):  # ahead of the node's folders: a half-present library is shadowed
        d.env = d.child_env(extra, [str(s) for s in stubs])
        still, other = probe.missing_libraries(binaries, d.env)
        other += list(still.values())
        d.say("the kit's stand-ins for " + ", ".join(probe.CAPABILITY_NAMES[c] for c in caps) + " let the programs "
              "start; the steps that use them are skipped")
    elif caps:
        other += [caps[c] for c in caps]
    d.missing.update(caps)
    if other:
        why = "the kit's programs cannot start here: " + "; ".join(other)
        d.outcomes.append(Outcome("libraries", "probe", 0, "FAILED", why=why))
        d.say(f"FAILED {why}")
        return False
    return True


def probe_gpu(env, kit):
    """(None, None) when the cuda backend runs here; else ('absent' or 'broken', why). Only exit 2 with 'needs an
    NVIDIA GPU' means absent: any other failure is one of the GPU code, reported as such."""
    try:
        p = subprocess.run([str(kit / "bin" / "poisson"), "--backend", "cuda", "--n", "4", "--quiet"], cwd=kit,
                           env=env, capture_output=True, text=True, timeout=120)
    except subprocess.TimeoutExpired:
        return "broken", "bin/poisson --backend cuda --n 4 did not end within 120 s"
    except OSError as e:
        return "broken", f"bin/poisson cannot run: {e}"
    if p.returncode == 0:
        return None, None
    if p.returncode == 2 and "needs an NVIDIA GPU" in p.stderr:
        return "absent", p.stderr.strip()
    return "broken", f"bin/poisson --backend cuda --n 4 exited {p.returncode}: {p.stderr.strip()}"


def write_machine(d, kit):
    """results/<label>/machine.json: common/machine_label.py --json, with nvidia-smi's fields, the kit's commit and
    what the probes found. A failure here is noted, never fatal."""
    machine = {}
    try:
        p = subprocess.run([sys.executable, "-B", str(kit / "common" / "machine_label.py"), "--json"], capture_output=True,
                           text=True, timeout=60)
        machine = json.loads(p.stdout)
    except (OSError, ValueError, subprocess.TimeoutExpired) as e:
        machine = {"label": d.label, "machine_label_failed": f"{type(e).__name__}: {e}"}
    smi = shutil.which("nvidia-smi", path=d.env.get("PATH", ""))
    if smi:
        try:
            q = subprocess.run([smi, "-q"], capture_output=True, text=True, timeout=60)
            (d.out / "logs" / "nvidia-smi-q.txt").write_text(q.stdout + q.stderr)
            machine["nvidia_smi"] = nvidia_smi_fields(smi)
        except (OSError, subprocess.TimeoutExpired) as e:
            machine["nvidia_smi"] = f"failed: {type(e).__name__}: {e}"
            d.say(f"nvidia-smi failed ({type(e).__name__}); going on")
    manifest = kit / "KIT-MANIFEST.json"
    machine["kit"] = json.loads(manifest.read_text()).get("git_commit") if manifest.exists() else None
    machine["probes"] = d.found
    machine["ld_library_path"] = d.env.get("LD_LIBRARY_PATH")
    (d.out / "results" / d.label / "machine.json").write_text(json.dumps(machine, indent=1) + "\n")


def nvidia_smi_fields(smi):
    fields = "name,driver_version,memory.total,clocks.max.sm,clocks.max.mem,clocks.sm,clocks.mem,power.limit," \
             "pci.bus_id,compute_mode"
    q = subprocess.run([smi, f"--query-gpu={fields}", "--format=csv,noheader"], capture_output=True, text=True,
                       timeout=60)
    return [dict(zip(fields.split(","), [v.strip() for v in l.split(",")])) for l in q.stdout.splitlines() if l]

