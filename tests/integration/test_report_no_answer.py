"""The report's extremes section quotes a run that is no answer (exit 3, 4, 5: no radiosity in its record) by its
exit status and reason instead of failing (found by a fresh clone's make reproduce: float Jacobi on the closed box of
rho = 0.9999 stagnates, exit 3)."""
import pandas as pd

from analysis import extremes


def test_extremes_quote_a_no_answer_run_by_its_reason(monkeypatch):
    rows = [{"app": "radiosity", "params.scene": "extremes/box_rho0.9999.xml", "params.method": "jacobi",
             "params.precision": "float", "params.tol": 1e-6, "result.status": "stagnant", "result.iterations": 25575,
             "result.exit_status": 3, "result.exit_reason": "no solution: jacobi: stalled",
             "result.radiosity_max": float("nan"), "result.error_vs_reference": float("nan")},
            {"app": "radiosity", "params.scene": "extremes/box_rho0.9.xml", "params.method": "jacobi",
             "params.precision": "double", "params.tol": 1e-6, "result.status": "converged", "result.iterations": 131,
             "result.exit_status": 0, "result.exit_reason": "", "result.radiosity_max": [10.0, 10.0, 10.0],
             "result.error_vs_reference": 1e-7}]
    monkeypatch.setattr(extremes, "load", lambda experiment, preset: pd.DataFrame(rows))
    lines = extremes.extreme_outcomes("quick")
    assert len(lines) == 2
    assert "rho = 0.9, Jacobi in double" in lines[0] and "B = 10" in lines[0]
    assert "rho = 0.9999" in lines[1] and "no answer, exit status 3" in lines[1] and "stalled" in lines[1]
