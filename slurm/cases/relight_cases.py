"""The relighting experiment's case list (issue 20), for slurm/cases/generate.py."""
from presets import SCENES, scene_args


# Real-time relighting (issue 20), per scene of the preset: random light mixes served from the light basis (every
# 20th frame checked against a cold float64 solve), a wall's reflectivity 10% lower and back, warm-started (Jacobi and
# BiCG-STAB to 1e-4, every frame's cold iterations beside it; Jacobi with F in float16 to 1e-3 within 50 ms), and the
# cold solve to 1e-6 the report would need per frame. The lines of a scene share one basis file (the first writes it).
# Each case times its own frames (the mixes: hundreds of them), and runs under the timing protocol as every timed
# experiment does (rounds, machine state, at least RELIGHT_REPEATS runs), so that each timing cell of the table has
# its median, 95% interval and n over runs; the CI preset runs each once (its records only check the pipeline).
RELIGHT_MIXES = {"quick": 200, "ci": 20, "paper": 1000}
RELIGHT_REPEATS = {"quick": 3, "ci": 1, "paper": 3}


def relight(preset, p):
    t = p["threads"]
    lines = []
    for s in p["scenes"]:
        name = SCENES[s][0]
        base = (f"bin/radiosity relight {scene_args(s, preset)} --basis {{FF_DIR}}/{preset}-{name}.basis "
                f"--threads {t}")
        wall = f"--frames radiosity/relight/frames/{name}-wall.json"
        lines += [f"{base} --random-frames {RELIGHT_MIXES[preset]} --check-every 20",
                  *(f"{base} {wall} --method {m} --tol 1e-4 --check-every 1" for m in ("jacobi", "bicgstab")),
                  f"{base} {wall} --method jacobi --ff-precision float16 --tol 1e-3 --frame-budget-ms 50 "
                  f"--check-every 1",
                  f"bin/radiosity solve {scene_args(s, preset)} --method jacobi --tol 1e-6 --backend openmp "
                  f"--threads {t}"]
    return {"relight": ("Real-time relighting: light mixes from the basis, warm-started reflectivity frames, and the "
                        "cold solve per frame they replace", RELIGHT_REPEATS[preset], lines)}
