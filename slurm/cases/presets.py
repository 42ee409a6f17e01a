"""The study's presets and scenes, which every case list of slurm/cases/generate.py is written from."""

# The report's scenes: 1 and 2 are ours (RRV does not ship them), 3 and 4 are RRV's room3.xml and room2.xml.
SCENES = {
    1: ("scene1", "radiosity/scenes/scene1.xml", ""),
    2: ("scene2", "radiosity/scenes/scene2.xml", ""),
    3: ("room3", "{RRV_SCENES}/room3.xml", " --allow-reflectivity-ge-1"),
    4: ("room2", "{RRV_SCENES}/room2.xml", ""),
}
# Jacobi iterations the report needed per scene (Table 4.2): RRV's original loop has no tolerance, so it runs
# this many fixed steps to do the same work as the tolerance runs beside it.
REPORT_JACOBI_ITERS = {1: 8, 2: 28, 3: 36, 4: 32}

PRESETS = {
    # min_time: the timing tables' solves take --min-time (common/repetitions.hpp): a solve shorter than that is timed as
    # the median of its repetitions in one process (scene 1's 3 ms solve about 30 of them), a longer one runs once as
    # before (issue 49: one run of a millisecond solve is at the mercy of one thread held up).
    # quick: scenes 1-3, a coarser hemicube, our exact weights, for 2 cores. Its timing tables (4.1-4.5) run each
    # case at least 6 times, as every preset: the fewest runs whose interval of the median reaches 95% (issue 49).
    "quick": dict(scenes=[1, 2, 3], hemicube=128, weights="exact", poisson_n=[256, 512, 1024], ranks=[1, 2],
                  cores=2, threads=2, hybrid_scene=3, mg_n=[256, 512, 1024, 2048], timing_repeat=6, min_time=0.1),
    # ci: tiny cases for the test that runs the harness under a real single-node Slurm.
    "ci": dict(scenes=[1], hemicube=16, weights="exact", poisson_n=[16, 32], ranks=[1, 2], cores=1, threads=1, hybrid_scene=1,
               mg_n=[16, 32], figure42=dict(divide=8, hemicube=8)),
    # paper: the report's sizes; RRV's hemicube (R = 256, its cos·cos weights) for a faithful reproduction. Its
    # OpenMP runs take every core the case may use ({CORES}: the machine's, or a Slurm job's), its ranks up to the
    # report's 16 (a case with more ranks than cores is skipped: slurm/run-case). Plain CG takes about N iterations
    # of N² work: at N = 8192 about half an hour a run on 2 cores, so those cases run `long_repeat` times at most.
    "paper": dict(scenes=[1, 2, 3, 4], hemicube=256, weights="rrv2007", poisson_n=[1024, 2048, 4096, 8192],
                  ranks=[1, 2, 4, 8, 16], cores=16, threads="{CORES}", hybrid_scene=4,
                  mg_n=[1024, 2048, 4096, 8192], timing_repeat=6, long_repeat={4096: 3, 8192: 2}, min_time=0.1),
}


def scene_args(s, preset):
    name, path, flag = SCENES[s]
    return f"{path}{flag} --ff {{FF_DIR}}/{preset}-{name}.ff"


def figure42_scene(preset, p, ff="--ff"):
    """Figure 4.2's scene 3 and its form factors: the preset's own, or (ci) a coarse room3 of its own."""
    if 3 in p["scenes"]:
        return scene_args(3, preset)
    return (f"{SCENES[3][1]}{SCENES[3][2]} --divide {p['figure42']['divide']:g} "
            f"{ff} {{FF_DIR}}/{preset}-room3-figure42.ff")
