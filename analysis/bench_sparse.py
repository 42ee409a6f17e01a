"""The bench-sparse table of `make bench` (issue 17): per scene and storage of F, a Jacobi step's bytes, time and
bandwidth against the read sweep measured next to it; and issue 17's and issue 37's target lines."""
import pandas as pd

from analysis import consistency
from analysis.bench_records import Interval, ci_of, limit_next_to, median_of, on_host, target
from analysis.records import load

# Issue 17's: CSR float32 on room3 within 1.25x of its matrix bytes at the read-sweep bandwidth next to it; the
# compressed storage (compressed or runs) at least 4x faster per Jacobi step than dense float32 on room3, in the same
# run.
CSR_SLACK, COMPRESSED_VS_DENSE = 1.25, 4.0
# Issue 37's: every sparse storage's room3 step within 1.3x of its matrix bytes at the corrected read bandwidth: the
# product's own read sweep (bin/radiosity solve --read-sweeps: the same arrays, read in the same process on the same
# threads right after the steps), where its records have it; else bin/stream's read-only sweep next to the case.
SPARSE_SLACK = 1.3
OWN_SWEEP = "perf.read_sweep_GBps"


def _own_sweep_records(r):
    """The records of one storage that carry the product's own read sweep, where any do: those supersede the
    records made before the bench asked for it (the same storage, another case line)."""
    if OWN_SWEEP not in r.columns or not r[OWN_SWEEP].notna().any():
        return r, False
    return r[r[OWN_SWEEP].notna()], True


def sparse_rows(preset, host, stream):
    """The bench-sparse table (issue 17): per scene and storage, the bytes of F a step reads, the time per step, its
    bandwidth, the read sweep next to it and the time over its limit (bytes / read sweep); and the target lines.
    Each repeat is set against the stream records beside it (slurm/bench runs the list in rounds), then medians."""
    df = on_host(load("bench-sparse", preset), host)
    if not len(df):
        return [], []
    out, targets, per = [], [], {}
    df = df.assign(scene_name=df["params.scene"].map(lambda x: x.rsplit("/", 1)[-1]))
    for scene, g in df.groupby("scene_name", sort=False):
        for k, ((storage, values), r) in enumerate(g.groupby(["params.storage", "params.ff_precision"], sort=False)):
            r, own = _own_sweep_records(r)
            nbytes = float(r["perf.matrix_bytes"].iloc[0])
            read = [limit_next_to(stream, r.iloc[[i]], "perf.read_GBps") for i in range(len(r))]
            t = median_of(r, "times_s.per_iteration")

            def over_at(bws):  # the step's time over its bytes at each repeat's bandwidth: median and interval
                return Interval.of([ti / (nbytes / (bw * 1e9)) for ti, bw in zip(r["times_s.per_iteration"], bws)])
            over = over_at(read)
            own_bw = list(r[OWN_SWEEP]) if own else None
            per[(scene, storage, values)] = (t, over, float(pd.Series(read).median()),
                                             over_at(own_bw) if own else None,
                                             float(pd.Series(own_bw).median()) if own else None, r)
            consistency.quote(f"{scene}: one Jacobi step, OpenMP, float (ms)",
                              f"make bench ({preset}), sparse table, {scene} {storage} {values}",
                              1e3 * r["times_s.per_iteration"], r)
            out.append({"problem": f"Jacobi step, {scene}, {int(r['params.patches'].iloc[0])} patches" if k == 0
                        else "", "storage": f"{storage} {values}", "MB of F per step": nbytes / 1e6,
                        # the row starts left out (runs: two arrays of them)
                        "bytes per entry": (nbytes - (16 if storage == "runs" else 8) *
                                            (int(r["params.patches"].iloc[0]) + 1)) /
                        float(r["result.kept"].iloc[0]) if storage != "dense" else None,
                        "ms per step": 1e3 * t, "95% interval (ms)": ci_of(r, "times_s.per_iteration", 1e3),
                        "GB/s": nbytes / t / 1e9,
                        "read sweep next to it": float(pd.Series(read).median()), "time / its limit": over.value,
                        "its own read sweep": per[(scene, storage, values)][4],
                        "time / its own limit": own_over.value if (own_over := per[(scene, storage, values)][3])
                        else None, "repeats": len(r)})
    csr, dense = per.get(("room3.xml", "csr", "float32")), per.get(("room3.xml", "dense", "float32"))
    if csr:
        targets.append(target(f"CSR float32 room3: its time over its matrix bytes at the read sweep next to it "
                              f"({csr[2]:.1f} GB/s)", csr[1], CSR_SLACK, "less", "x"))
    for (scene, storage, values), (_, over, bw, own_over, own_bw, _r) in per.items():
        if scene == "room3.xml" and storage != "dense":
            if own_over is not None:
                over, bw, where = own_over, own_bw, "its own read sweep (the same arrays, read in the same process)"
            else:
                where = "the read sweep next to it"
            targets.append(target(f"{storage} {values} room3: its time over its matrix bytes at {where} "
                                  f"({bw:.1f} GB/s)", over, SPARSE_SLACK, "less", "x"))
    for storage, values in (("runs", "float16"), ("runs", "float32"), ("compressed", "float16"), ("compressed", "float32")):
        comp = per.get(("room3.xml", storage, values))
        if comp and dense:
            iv = Interval.paired(dense[5], comp[5], "times_s.per_iteration")
            if iv is None:
                x = dense[0] / comp[0]
                iv = Interval(x, x, x, 1, "ratio of medians, not paired")
            targets.append(target(f"{storage} {values} room3: times faster per Jacobi step than dense float32 "
                                  f"({1e3 * comp[0]:.2f} against {1e3 * dense[0]:.2f} ms)", iv, COMPRESSED_VS_DENSE,
                                  "greater", "x"))
    return out, targets
