"""make bench's case lists (slurm/bench runs them): the bandwidth limit, our solvers and their peers."""

def bench(preset, p):
    """make bench (slurm/bench runs these in order, the bandwidth limit again before every case): the bandwidth
    limit, each solver's time per iteration, and the peers (SciPy, NumPy with OpenBLAS) on the same problems with
    the same threads. Room3's form factors at R = 256 are the hemicube case's output, read by the Jacobi cases with
    our 32 steps (slurm/bench makes both once)."""
    t = p["threads"]
    room3 = "{RRV_SCENES}/room3.xml --allow-reflectivity-ge-1"
    ff = "{FF_DIR}/bench-room3.ff"
    peer = ".venv/bin/python -m bench.peers"
    e = {}
    e["bench-stream"] = ("Bench: memory bandwidth (STREAM triad, read-only sweep), run by slurm/bench before every "
                         "other bench case", None, [f"bin/stream --threads {t}"])
    # Full solves where SciPy takes seconds; beyond, the same capped iterations for everyone, enough for ours to
    # run a second or more (this VM's first few hundred milliseconds of a run are slower).
    cg = [(256, None), (512, None), (1024, 200), (2048, 200)]
    e["bench-cg"] = ("Bench: Poisson CG per iteration, ours (both variants) and SciPy's sparse.linalg.cg", None, [
        line for n, cap in cg for line in (
            *(f"bin/poisson --backend openmp --threads {t} --n {n} --variant {v}{f' --steps {cap}' if cap else ''}"
              for v in ("onesweep", "classic")),
            f"{peer} scipy-cg --threads {t} --n {n}{f' --max-iter {cap}' if cap else ''}")])
    # MG-PCG against PETSc (CG, CG + hypre BoomerAMG, CG + GAMG: bench/petsc_poisson.py) on as many ranks as our
    # threads, the same problem, tolerance and norm; slurm/bench runs this list in rounds (every case's repeat r
    # before any case's r + 1), so ours and the peers alternate. Plain CG: full solves at N = 512, where the
    # iteration counts must agree, and 200 capped iterations at 2048 for the time per iteration. N = 8192: ours.
    petsc = f"ranks={t} /usr/bin/python3 bench/petsc_poisson.py"
    mg = f"bin/poisson --backend openmp --threads {t} --precond mg"
    fmg = f"bin/poisson --backend openmp --threads {t} --method fmg"
    dst = f".venv/bin/python -m bench.dst_poisson --threads {t}"
    e["bench-mg"] = ("Bench: MG-PCG and FMG to 1e-6 against PETSc CG, CG + hypre BoomerAMG, CG + GAMG, CG + "
                     "geometric MG and the DST direct solver; plain CG per iteration against PETSc's CG", None, [
        f"bin/poisson --backend openmp --threads {t} --n 512", f"{petsc} --n 512 --pc none",
        f"bin/poisson --backend openmp --threads {t} --n 2048 --steps 200", f"{petsc} --n 2048 --pc none --max-iter 200",
        *(line for n in (1024, 2048, 4096) for line in (
            f"{mg} --n {n}", f"{petsc} --n {n} --pc hypre", f"{petsc} --n {n} --pc gamg")),
        f"{mg} --n 8192",
        # Issue 37: full multigrid against the direct fast solver (DST-I by scipy.fft and by FFTW), the same threads,
        # at our sizes and at the transforms' good ones (N + 1 a power of two), MG-PCG beside them.
        *(line for n in (2048, 4096, 4095, 8192, 8191) for line in (
            f"{fmg} --n {n}", *(f"{dst} --n {n} --fft {fft}" for fft in ("scipy", "fftw")))),
        f"{mg} --n 8191",
        # PETSc's geometric multigrid (PCMG on the DMDA's hierarchy, Galerkin) at a size a DMDA halves to the end
        # (N = 2^k + 1), ours beside it; last, so that the cases above keep their numbers.
        f"{mg} --n 4097", f"{fmg} --n 4097", f"{petsc} --n 4097 --pc mg"])
    e["bench-hemicube"] = ("Bench: form factors of room3.xml by the hemicube, R = 256, patches per second", None, [
        f"bin/radiosity formfactors {room3} -o {ff} --hemicube 256 --weights exact --threads {t}"])
    e["bench-jacobi"] = ("Bench: Jacobi steps on room3.xml, float32, ours (AOS, SOA; F in float32, float16, bfloat16) "
                         "and NumPy (sgemm, 3 sgemv)", None, [
        *(f"bin/radiosity solve {room3} --ff {ff} --steps 32 --backend openmp --precision float --layout {l} "
          f"--threads {t}" for l in ("aos", "soa")),
        *(f"bin/radiosity solve {room3} --ff {ff} --steps 32 --backend openmp --precision float --layout aos "
          f"--ff-precision {v} --threads {t}" for v in ("float16", "bfloat16")),
        *(f"{peer} numpy-jacobi {{RRV_SCENES}}/room3.xml --ff {ff} --solved {{FF_DIR}}/bench-room3-solved.xml --steps 32 --way {w} "
          f"--threads {t}" for w in ("gemm", "gemv"))])
    # Issue 17: the sparse storages beside dense float32 on room3 (R = 256) and room2 (R = 64, made by slurm/bench),
    # 32 Jacobi steps each; slurm/bench runs this list in rounds, so the storages alternate in the same minutes, and
    # analysis.bench sets each against its matrix bytes over the read sweep measured next to it, and (issue 37) over
    # its own read sweep: --read-sweeps 32, the same arrays read 32 times right after the steps, in the same process.
    sparse = [("dense", "float32"), ("csr", "float32"), ("compressed", "float32"), ("compressed", "float16"),
              ("runs", "float32"), ("runs", "float16")]
    e["bench-sparse"] = ("Bench: Jacobi steps on room3.xml and room2.xml, F dense float32 beside csr, compressed and "
                         "runs (float32, float16 values), each against its bytes over the read sweep", 5, [
        f"bin/radiosity solve {sc} --ff {f} --steps 32 --backend openmp --precision float --layout aos "
        f"--storage {st} --ff-precision {v} --threads {t} --no-verify --read-sweeps 32"
        for sc, f in ((room3, ff), ("{RRV_SCENES}/room2.xml", "{FF_DIR}/bench-room2.ff")) for st, v in sparse])
    # Issue 20: the product with k right-hand sides (one pass over F), room2's basis frames (its form factors at
    # R = 64, made once by slurm/bench) and room3's wall 10% darker, warm-started.
    relight = f"bin/radiosity relight {room3} --ff {ff} --threads {t}"
    # The product over F in runs (what --storage auto picks on room3) and in dense beside it, each storage named: k = 1
    # reads that storage, k >= 2 the row blocks built from it (the same blocks from either).
    e["bench-relight"] = ("Bench: relighting: the product with k = 1 .. 16 right-hand sides on room3 (runs and dense, "
                          "float32 and float16), room2's basis frames, room3's wall frames warm-started", None, [
        *(f"{relight} --bench-rhs {k} --ff-precision {v} --storage {st} --passes 10" for st in ("runs", "dense")
          for v in ("float32", "float16") for k in (1, 2, 4, 8, 16)),
        f"bin/radiosity relight {{RRV_SCENES}}/room2.xml --ff {{FF_DIR}}/bench-room2.ff --threads {t} "
        f"--basis {{FF_DIR}}/bench-room2.basis --random-frames 10000",
        *(f"{relight} --basis {{FF_DIR}}/bench-room3.basis --frames radiosity/relight/frames/room3-wall.json "
          f"--method {m} --tol 1e-4 --check-every 1" for m in ("jacobi", "bicgstab")),
        *(f"{relight} --basis {{FF_DIR}}/bench-room3.basis --frames radiosity/relight/frames/room3-wall.json "
          f"--method {m} --ff-precision float16 --tol 1e-3 --check-every 1" for m in ("jacobi", "bicgstab"))])
    return e
