"""The speed-against-accuracy fronts are monotone where the work is (issue 31): within one solver configuration of a
sweep, more iterations never take less time. A sweep runs each setting once, and a run of a few milliseconds is
mostly noise, so a setting's time is its configuration's median setup + iterations x median time per iteration
(analysis/accuracy.py, solver_time); the measured time stays beside it."""
import pandas as pd

from analysis import accuracy, records
from conftest import ROOT

REFERENCE = (ROOT / "results" / "REFERENCE").read_text().strip()


def noisy_sweep():
    """One configuration, 1 to 64 steps at 0.1 ms a step, each run's time off by up to +-60% (a loaded machine)."""
    noise = [1.6, 0.4, 1.5, 0.5, 1.3, 0.6, 1.0]
    steps = [1, 2, 4, 8, 16, 32, 64]
    return pd.DataFrame({"experiment": "accuracy-tolerance", "params.scene": "s.xml", "params.method": "jacobi",
                         "params.precision": "float", "params.ff_precision": "float32", "params.storage": "dense",
                         "params.threshold": 0.0, "params.omega": None, "params.ff_file": "s.ff",
                         "params.divide": None, "result.iterations": steps,
                         "times_s.solve": [1e-4 * k * f for k, f in zip(steps, noise)], "times_s.setup": 1e-5,
                         "measured_s": [1e-5 + 1e-4 * k * f for k, f in zip(steps, noise)]})


def test_a_configurations_time_grows_with_its_iterations_where_single_runs_do_not():
    df = noisy_sweep()
    assert not df["measured_s"].is_monotonic_increasing  # the noise the issue saw: 2 steps faster than 1
    t = accuracy.solver_time(df)
    assert t.is_monotonic_increasing and t.iloc[-1] / t.iloc[0] > 30
    # two configurations never share a time per iteration
    other = noisy_sweep().assign(**{"params.precision": "double", "times_s.solve": lambda d: 3 * d["times_s.solve"]})
    both = pd.concat([df, other], ignore_index=True)
    t2 = accuracy.solver_time(both)
    assert (t2.iloc[7:].values > 2 * t2.iloc[:7].values).all()


def test_the_reference_fronts_are_monotone_where_the_work_is():
    with records.on(REFERENCE):
        df = accuracy.solves("quick")
    solver = df[df["family"] == "solver"]
    assert len(solver) > 50
    for key, g in solver.groupby(["scene", "experiment", "method", "precision", "ff_precision", "storage", "threshold"],
                                 dropna=False):
        g = g.sort_values("iterations")
        more = g["iterations"].diff() > 0
        assert (g["time_s"].diff()[more] >= 0).all(), (key, g[["setting", "iterations", "time_s"]])
