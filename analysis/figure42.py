"""Figure 4.2: the scene after 1, 2, 4, 8 and 32 Jacobi steps, in one row, from the snapshots the figure42
experiment wrote."""
import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402

from analysis.records import machine_dir, plots_dir  # noqa: E402

STEPS = (1, 2, 4, 8, 32)


def write(preset):
    files = [machine_dir() / "figure42" / preset / f"room3_iter{k}.png" for k in STEPS]
    if not all(f.exists() for f in files):
        return None
    fig, axes = plt.subplots(1, len(STEPS), figsize=(3 * len(STEPS), 2.6))
    for ax, k, f in zip(axes, STEPS, files):
        ax.imshow(mpimg.imread(f))
        ax.set_title(f"{k} iteration{'s' if k > 1 else ''}")
        ax.axis("off")
    fig.suptitle(f"Figure 4.2 ({preset}): room3.xml during Jacobi")
    fig.tight_layout()
    plots_dir().mkdir(parents=True, exist_ok=True)
    out = plots_dir() / f"figure42_{preset}.png"
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return out
