"""Scaling on paper (issue 35): a latency-bandwidth model of both MPI programs, past the machines we have.

Per iteration, a rank's time is its computation plus its communication:
  Poisson CG (classic, poisson/backends/mpi.cpp), an N x N grid in row blocks over P ranks:
    compute  N²/P grid points x V vectors x 8 bytes / the rank's memory bandwidth (V = 11: perf.vectors_per_iteration)
    halo     2 messages (one row of p to each neighbour), 8 N bytes each:  2 (alpha + 8 N / beta)
    allreduce 2 dot products of 8 bytes:                                   2 ceil(log2 P) (alpha + 8 / beta)
  Radiosity Jacobi (--backend mpi, radiosity/solve/mpi/mpi.cpp), n patches, F in float32, rows in blocks over P ranks:
    compute  n²/P entries of F x 4 bytes / the rank's memory bandwidth (the product is bound by reading F)
    gather   one MPI_Allgatherv of the vector, n x 3 channels x 8 bytes (ring): (P - 1) alpha + (P - 1)/P 24 n / beta
    allreduce 1 of 3 doubles (the residual):                               ceil(log2 P) (alpha + 24 / beta)
The message counts and bytes are the programs' own (the solve records say them: mpi.allgatherv_per_iteration,
mpi.gather_bytes_per_call, mpi.allreduce_per_iteration); alpha (latency, s) and beta (bandwidth, bytes/s) are the
network's parameters. Every rank is counted as talking over the network (ranks on one node share memory in fact:
the model is pessimistic by that much). A maya-like cluster (72 nodes of 2 x 8 cores, QDR InfiniBand) is MAYA below.

  python -m analysis.scaling_model [--measured DIR] [--out DIR]
DIR holds K1/, K2/, K3/ (slurm/mpi-nodes.sbatch's records, one rank per node): the model's check. The ranks' memory
bandwidth is fitted to Poisson at K = 1, the latency to Poisson at K = 2 (beta fixed, LOCAL_BETA); Poisson at K = 3
and radiosity at K = 2, 3 (another shape of communication) are then predictions. The namespaced nodes share this
machine's cores (--cores): K ranks on fewer cores compute K/cores times slower each."""
import argparse
import json
import math
import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

# A maya-like cluster: 72 nodes, 2 x 8 cores, QDR InfiniBand (about 1.5 us and 3.2 GB/s for MPI), about 40 GB/s of
# memory bandwidth per node under STREAM. Parameters, not measurements: change them for another machine.
MAYA = {"nodes": 72, "cores": 16, "alpha": 1.5e-6, "beta": 3.2e9, "node_bw": 40e9}
POISSON_V = 11  # a model parameter: vectors of N² per classic CG iteration (bin/poisson --list-backends: mpi, classic)


def log2p(p):
    return math.ceil(math.log2(p)) if p > 1 else 0


def poisson(n, p, rank_bw, alpha, beta):
    """(compute, communication) seconds of one CG iteration on P ranks."""
    comp = n * n / p * POISSON_V * 8 / rank_bw
    comm = 0.0 if p == 1 else 2 * (alpha + 8 * n / beta) + 2 * log2p(p) * (alpha + 8 / beta)
    return comp, comm


def radiosity(n, p, rank_bw, alpha, beta):
    """(compute, communication) seconds of one Jacobi step on P ranks."""
    comp = n * n / p * 4 / rank_bw
    comm = 0.0 if p == 1 else (p - 1) * alpha + (p - 1) / p * 24 * n / beta + log2p(p) * (alpha + 24 / beta)
    return comp, comm


def crossover(model, n_of_p, m=MAYA):
    """The fewest nodes (16 ranks each) at which communication takes longer than computation, or None."""
    for nodes in range(1, m["nodes"] + 1):
        p = nodes * m["cores"]
        comp, comm = model(n_of_p(p), p, m["node_bw"] / m["cores"], m["alpha"], m["beta"])
        if comm > comp:
            return nodes
    return None


STUDIES = {  # name: (model, problem size as a function of P)
    "Poisson strong, N = 1024": (poisson, lambda p: 1024),
    "Poisson strong, N = 4096": (poisson, lambda p: 4096),
    "Poisson weak, N = 1024 sqrt(P/16)": (poisson, lambda p: int(1024 * math.sqrt(p / 16))),
    "radiosity strong, n = 20000": (radiosity, lambda p: 20000),
    "radiosity weak, n = 5000 sqrt(P/16)": (radiosity, lambda p: int(5000 * math.sqrt(p / 16))),
}


def last(path):
    return json.loads(Path(path).read_text().splitlines()[-1])


def measured(d):
    """Per K: the Poisson and radiosity records of K ranks on K nodes (DIR/K1, K2, K3)."""
    out = {}
    for k in (1, 2, 3):
        sub = Path(d) / f"K{k}"
        if (sub / "poisson.jsonl").exists() and (sub / "solve.jsonl").exists():
            out[k] = (last(sub / "poisson.jsonl"), last(sub / "solve.jsonl"))
    return out


def per_step(rec):
    return rec["times_s"]["solve"] / max(rec["result"]["iterations"], 1)


LOCAL_BETA = 1e9  # bytes/s between two namespaces (TCP over veth): a parameter; the latency is what is fitted


def share(p, cores):
    """How many ranks share a core: P ranks on a machine of `cores` cores (the namespaced nodes share them)."""
    return max(1.0, p / cores)


def fit(meas, cores):
    """The ranks' bandwidth from K = 1 (all computation) and the network's latency alpha from K = 2 (the time it adds
    past half of K = 1's, over its 4 messages: 2 halo rows, 2 allreduces), with beta = LOCAL_BETA."""
    p1, p2 = meas[1][0], meas[2][0]
    n1, n2 = p1["params"]["n"], p2["params"]["n"]
    rank_bw = n1 * n1 * POISSON_V * 8 / p1["times_s"]["per_iteration"]
    comp2 = poisson(n2, 2, rank_bw / share(2, cores), 1.0, 1.0)[0]
    alpha = (p2["times_s"]["per_iteration"] - comp2 - (16 * n2 + 16) / LOCAL_BETA) / 4
    return rank_bw, max(alpha, 1e-7), LOCAL_BETA


def check(meas, cores):
    """Rows (program, K, measured s/iteration, predicted s/iteration) and the parameters: fitted on Poisson K = 1
    and 2, the rest (Poisson K = 3, radiosity K = 2, 3) are predictions."""
    rank_bw, alpha, beta = fit(meas, cores)
    r1 = meas[1][1]
    n_r = r1["params"]["patches"]
    r_bw = n_r * n_r * 4 / per_step(r1)  # the product's own bandwidth, from K = 1
    rows = []
    for k, (p, r) in sorted(meas.items()):
        model = sum(poisson(p["params"]["n"], k, rank_bw / share(k, cores), alpha, beta))
        rows.append(("Poisson CG", k, p["times_s"]["per_iteration"], model))
        rows.append(("radiosity Jacobi", k, per_step(r), sum(radiosity(n_r, k, r_bw / share(k, cores), alpha, beta))))
    return rows, {"alpha_s": alpha, "beta_Bps": beta, "poisson_rank_bw_Bps": rank_bw, "radiosity_rank_bw_Bps": r_bw}


def plot(path, rows=None):
    fig, axes = plt.subplots(1, 3 if rows else 2, figsize=(15 if rows else 10, 4))
    nodes = np.arange(1, MAYA["nodes"] + 1)
    for ax, kind in zip(axes, ("strong", "weak")):
        for name, (model, size) in STUDIES.items():
            if kind not in name:
                continue
            ps = nodes * MAYA["cores"]
            t = np.array([model(size(p), p, MAYA["node_bw"] / MAYA["cores"], MAYA["alpha"], MAYA["beta"]) for p in ps])
            line, = ax.loglog(nodes, t[:, 0], label=f"{name}: compute")
            ax.loglog(nodes, t[:, 1], "--", color=line.get_color(), label=f"{name}: communication")
        ax.set(title=f"maya-like model, {kind} scaling", xlabel="nodes (16 ranks each)", ylabel="s per iteration")
        ax.legend(fontsize=7)
    if rows:
        ax = axes[2]
        for prog, marker, color in (("Poisson CG", "o", "C0"), ("radiosity Jacobi", "s", "C2")):
            ks = [r[1] for r in rows if r[0] == prog]
            ax.plot(ks, [r[2] for r in rows if r[0] == prog], marker, color=color, label=f"{prog}: measured")
            ax.plot(ks, [r[3] for r in rows if r[0] == prog], "--", marker=marker, mfc="none", color=color,
                    label=f"{prog}: model")
        ax.set(title="K namespaced nodes, 1 rank each (loaded machine)", xlabel="K nodes",
               ylabel="s per iteration", xticks=[1, 2, 3])
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--measured", help="folder with K1/ K2/ K3/ records of slurm/mpi-nodes.sbatch")
    ap.add_argument("--cores", type=int, default=os.cpu_count(), help="cores the measured nodes shared")
    ap.add_argument("--out", default="build/scaling-model", help="where the table and the plot go")
    a = ap.parse_args(argv)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    print(f"maya-like parameters: {MAYA}")
    for name, (model, size) in STUDIES.items():
        c = crossover(model, size)
        print(f"{name}: communication overtakes computation at {c if c else 'more than 72'} nodes")
    rows = None
    if a.measured:
        meas = measured(a.measured)
        if 1 not in meas or 2 not in meas:
            ap.exit(2, f"scaling_model: {a.measured} needs K1/ and K2/ (poisson.jsonl, solve.jsonl)\n")
        rows, params = check(meas, a.cores)
        print("fitted on Poisson K = 1, 2: " + ", ".join(f"{k} {v:.3g}" for k, v in params.items()))
        print("| program | K | measured s/iteration | model s/iteration | model/measured |\n|---|---|---|---|---|")
        for prog, k, m, p in rows:
            print(f"| {prog} | {k} | {m:.3g} | {p:.3g} | {p / m:.2f} |")
    plot(out / "scaling-model.png", rows)
    print(f"plot: {out / 'scaling-model.png'}")


if __name__ == "__main__":
    main()
