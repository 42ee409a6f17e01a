"""A table with no records still states its settings (issue 34), read from its case list (slurm/cases/<preset>/) and
the form-factor records of its scenes: scene (the report's or our stand-in), weights, hemicube, tolerance, storage,
precision, threads and ranks."""
import sys

import pandas as pd

from conftest import ROOT

sys.path.insert(0, str(ROOT))
from analysis import records, settings  # noqa: E402


def test_an_empty_table_states_the_settings_of_its_case_list(monkeypatch):
    ff = pd.DataFrame([{"params.scene": "rrv/room2.xml", "params.hemicube": 256, "params.weights": "rrv2007"},
                       {"params.scene": "radiosity/scenes/scene1.xml", "params.hemicube": 64, "params.weights": "exact"}])
    monkeypatch.setattr(records, "load", lambda experiment, preset: ff if experiment == "formfactors" else pd.DataFrame())
    line = settings.planned("table45", "paper", "the report's: scene 4")
    assert line.startswith("Settings (of the case list; no runs of it used here): preset paper;")
    for part in ("scene 4 (RRV's room2.xml, the report's)", "hemicube weights rrv2007", "hemicube resolution 256",
                 "tolerance 1e-06", "precision float", "F stored dense float32", "the report's: scene 4"):
        assert part in line, line
    assert "scene 1" not in line and "resolution 64" not in line  # only the scenes the case list runs
    poisson = settings.planned("table41", "paper")
    assert "precision double" in poisson and "1, 2, 4, 8, 16 MPI rank(s)" in poisson, poisson
    assert settings.planned("no-such-list", "paper") == "Settings: preset paper."
