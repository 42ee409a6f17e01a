"""Radiosity across nodes (issue 9): case lists for slurm/cases/generate.py."""
from presets import SCENES


# Radiosity across nodes (issue 9): form factors and solves on MPI ranks, each rank its block of rows of F.
# strong: one scene, P = 1 .. ranks; weak: patches n growing as √P, so that a rank's share of the dense F (4n²/P
# bytes, the memory that decides how many nodes a scene needs) stays about the same: --divide values picked from
# the patch counts `bin/radiosity info` gives (noted beside each). large: a scene one rank may not hold
# (--max-memory-per-rank), its form factors and solve on enough ranks; in the paper preset a scene too large for one
# node's memory, across 4 nodes (slurm/mpi-large.sbatch says how its size was chosen).
MPI = {
    "quick": dict(scene=2, hemicube=64, ranks=[1, 2, 3, 4], threads=1,
                  # scene2 at these divides: 2064, 2532, 3360, 4128 patches; n²/P = 4.26, 3.21, 3.76, 4.26 M
                  weak=[(1, 2, 4.0), (2, 2, 1.4), (3, 2, 1.0), (4, 2, 0.8)],
                  # scene2: F 43.1 MiB; 16 MiB per rank needs 4 ranks for the solve (3 for the form factors)
                  large=dict(scene=2, divide=1.0, ranks=4, limit="16M")),
    "ci": dict(scene=1, hemicube=16, ranks=[1, 2], threads=1,
               weak=[(1, 1, 1.0), (2, 1, 0.55)],  # 1312, 2080 patches: n²/P = 1.72, 2.16 M
               large=dict(scene=1, divide=1.0, ranks=2, limit="5M")),  # F 6.6 MiB: 2 ranks hold 4.1 MiB each
    "paper": dict(scene=4, hemicube=256, ranks=[1, 2, 4, 8, 16], threads=1,
                  # room2 at these divides: 17128, 44872, 66040 patches; n²/P = 293, 252, 273 M (room2's mesh
                  # refines in steps: nothing between 18760 and 43336 patches for P = 2 or 4)
                  weak=[(1, 4, 1.0), (8, 4, 0.5), (16, 4, 0.15)],
                  # room2 at --divide 0.1: 221407 patches, F 182.6 GiB: 4 nodes of 16 ranks (slurm/mpi-large.sbatch)
                  large=dict(scene=4, divide=0.1, ranks=64, limit="3.5G")),
}


def mpi_experiments(preset, p):
    m = MPI[preset]
    def ff(name):
        return f"{{FF_DIR}}/{preset}-mpi-{name}.ff"

    hemi = f"--hemicube {m['hemicube']} --weights {p['weights']} --threads {m['threads']}"

    def scene(s, divide):
        return f"{SCENES[s][1]}{SCENES[s][2]}" + (f" --divide {divide:g}" if divide != 1.0 else "")

    strong = SCENES[m["scene"]][0]
    top = max(m["ranks"])
    even = min(top, max(2, p["cores"]))
    e = {}
    # Six repeats, as every timed group (issue 49): a rank's hemicube time varies by about 10% from run to run on a
    # shared machine, as much as the split by work gains over equal counts.
    e["mpi-formfactors"] = ("Radiosity across nodes: form factors on P MPI ranks, one file written together (MPI-IO); "
                            f"strong scaling on {strong}, weak scaling (patches grow as sqrt(P))", 6, [
        *(f"ranks={r} bin/radiosity formfactors {scene(m['scene'], 1.0)} -o {ff(f'{strong}-P{r}')} {hemi}"
          for r in m["ranks"]),
        *(f"ranks={r} bin/radiosity formfactors {scene(s, d)} -o {ff(f'weak-P{r}')} {hemi}"
          for r, s, d in m["weak"]),
        # the same rows in blocks of equal count, to see what the split by estimated work buys (at as many ranks as
        # the preset's node has cores, so that the ranks do not share cores)
        f"ranks={even} bin/radiosity formfactors {scene(m['scene'], 1.0)} -o {ff(f'{strong}-P{even}-rows')} {hemi} "
        f"--split rows"])
    solve = f"--tol 1e-6 --threads {m['threads']}"
    # The solves read the file written by one rank: a file does not depend on who wrote it, and one rank's is there on
    # any machine (the cases with more ranks than cores are skipped).
    strong_ff = ff(f"{strong}-P{min(m['ranks'])}")
    e["mpi-radiosity"] = ("Radiosity across nodes: Jacobi and BiCG-STAB on P MPI ranks (--backend mpi) beside one "
                          "process (openmp); strong scaling and weak scaling", p.get("timing_repeat"), [
        *(f"bin/radiosity solve {scene(m['scene'], 1.0)} --ff {strong_ff} --method {meth} --backend openmp {solve}"
          for meth in ("jacobi", "bicgstab")),
        *(f"ranks={r} bin/radiosity solve {scene(m['scene'], 1.0)} --ff {strong_ff} --method {meth} --backend mpi {solve}"
          for meth in ("jacobi", "bicgstab") for r in m["ranks"]),
        *(f"ranks={r} bin/radiosity solve {scene(s, d)} --ff {ff(f'weak-P{r}')} --method jacobi "
          f"--backend mpi {solve}" for r, s, d in m["weak"])])
    lg = m["large"]
    big = ff("large")
    e["mpi-large"] = (f"Radiosity across nodes: a scene one rank may not hold (--max-memory-per-rank {lg['limit']}), its "
                      f"form factors and Jacobi solve on {lg['ranks']} ranks; run in order by slurm/mpi-large.sbatch", 1, [
        f"ranks={lg['ranks']} bin/radiosity formfactors {scene(lg['scene'], lg['divide'])} -o {big} {hemi} "
        f"--max-memory-per-rank {lg['limit']}",
        f"ranks={lg['ranks']} bin/radiosity solve {scene(lg['scene'], lg['divide'])} --ff {big} --method jacobi "
        f"--backend mpi {solve} --max-memory-per-rank {lg['limit']}"])
    return e
