"""The scaling model on paper (analysis/scaling_model.py, issue 35): its terms behave as the programs' communication
does, and its command line makes the plot and refuses a measured folder without K = 1 and K = 2."""
import json

from analysis import scaling_model as sm
from conftest import ROOT, run

BW = sm.MAYA["node_bw"] / sm.MAYA["cores"]


def test_one_rank_has_no_communication_and_more_ranks_less_computation():
    for model in (sm.poisson, sm.radiosity):
        comp1, comm1 = model(1024, 1, BW, 1e-6, 1e9)
        comp4, comm4 = model(1024, 4, BW, 1e-6, 1e9)
        assert comm1 == 0 and comm4 > 0 and abs(comp4 * 4 - comp1) < 1e-15


def test_the_gather_grows_with_ranks_the_halo_does_not():
    # radiosity gathers the whole vector: (P - 1) latencies; Poisson's halo is 2 rows whatever P (log P allreduces)
    a, b = 1e-6, 1e9
    assert sm.radiosity(5000, 64, BW, a, b)[1] - sm.radiosity(5000, 2, BW, a, b)[1] > 62 * a
    grown = sm.poisson(1024, 64, BW, a, b)[1] - sm.poisson(1024, 2, BW, a, b)[1]
    assert abs(grown - 2 * (6 - 1) * (a + 8 / b)) < 1e-15


def test_crossover_is_where_communication_passes_computation():
    nodes = sm.crossover(sm.radiosity, lambda p: 20000)
    p = nodes * 16
    comp, comm = sm.radiosity(20000, p, BW, sm.MAYA["alpha"], sm.MAYA["beta"])
    assert comm > comp
    comp, comm = sm.radiosity(20000, p - 16, BW, sm.MAYA["alpha"], sm.MAYA["beta"])
    assert comm <= comp


def fake(d, k, t_poisson, t_step):
    (d / f"K{k}").mkdir(parents=True)
    (d / f"K{k}" / "poisson.jsonl").write_text(json.dumps(
        {"params": {"n": 512}, "times_s": {"per_iteration": t_poisson}}) + "\n")
    (d / f"K{k}" / "solve.jsonl").write_text(json.dumps(
        {"params": {"patches": 1312}, "result": {"iterations": 10}, "times_s": {"solve": 10 * t_step}}) + "\n")


def test_the_check_fits_k1_k2_and_predicts_k3(tmp_path):
    fake(tmp_path, 1, 2e-3, 1e-3)
    fake(tmp_path, 2, 1.2e-3, 0.7e-3)
    fake(tmp_path, 3, 1e-3, 0.6e-3)
    rows, params = sm.check(sm.measured(tmp_path), cores=4)
    by = {(r[0], r[1]): r for r in rows}
    assert abs(by["Poisson CG", 1][3] - 2e-3) < 1e-12 and abs(by["Poisson CG", 2][3] - 1.2e-3) < 1e-12
    assert params["alpha_s"] > 0 and by["Poisson CG", 3][3] > 0


def test_the_command_makes_the_plot_and_refuses_a_folder_without_k2(tmp_path):
    p = run([ROOT / ".venv" / "bin" / "python", "-m", "analysis.scaling_model", "--out", tmp_path], cwd=ROOT)
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "scaling-model.png").stat().st_size > 0 and "communication overtakes" in p.stdout
    fake(tmp_path / "m", 1, 2e-3, 1e-3)
    p = run([ROOT / ".venv" / "bin" / "python", "-m", "analysis.scaling_model", "--measured", tmp_path / "m",
             "--out", tmp_path], cwd=ROOT)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1
