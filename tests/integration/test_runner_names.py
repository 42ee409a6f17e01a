"""Experiment and preset names are names, never paths (issue 33): each runner script refuses one that would lead out
of the case lists or out of the machine's folder, with one line and exit 2, before it writes or runs anything."""
import pytest

from conftest import ROOT, run

# Each a path or a pattern, none of them spelled as the issue's ../quick/formfactors.
BAD_EXPERIMENTS = ["./table41", "../ci/table41", "table41\nformfactors", ""]
BAD_PRESETS = ["../cases/ci", "c?"]


def script(name, *args, env):
    return run([ROOT / "slurm" / name, *args], env=env, timeout=120, cwd=ROOT)


def one_line_refusal(p, results):
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 2 and len(lines) == 1, (p.returncode, p.stdout, p.stderr)
    assert not results.exists(), "something was written"


@pytest.fixture
def env(tmp_path):
    return {"RESULTS": str(tmp_path / "results"), "FF_DIR": str(tmp_path / "ff"), "MACHINE": "t", "DRY_RUN": "1",
            "RESUME": "1"}


@pytest.mark.parametrize("exp", BAD_EXPERIMENTS)
def test_an_experiment_that_is_a_path_is_refused_by_every_runner(tmp_path, env, exp):
    env = {**env, "PRESET": "ci"}
    for args in (["run-case", exp, "0"], ["run-local", exp], ["submit", exp], ["missing", exp]):
        one_line_refusal(script(*args, env=env), tmp_path / "results")
    if exp:
        one_line_refusal(script("bench", env={**env, "BENCH": exp}), tmp_path / "results")


@pytest.mark.parametrize("preset", BAD_PRESETS)
def test_a_preset_that_is_a_path_is_refused_by_every_runner(tmp_path, env, preset):
    env = {**env, "PRESET": preset}
    for args in (["run-case", "table41", "0"], ["run-local", "table41"], ["submit", "table41"], ["missing", "table41"],
                 ["bench"]):
        one_line_refusal(script(*args, env=env), tmp_path / "results")
    p = run([ROOT / ".venv" / "bin" / "python", ROOT / "slurm" / "audit", preset], env=env, cwd=ROOT)
    one_line_refusal(p, tmp_path / "results")


def test_good_names_still_run(tmp_path, env):
    p = script("run-case", "table41", "0", env={**env, "PRESET": "ci"})
    assert p.returncode == 0 and "would run" in p.stdout, p.stderr
    p = script("missing", "table41", env={**env, "PRESET": "ci"})
    assert p.returncode == 0 and p.stdout.startswith("0"), p.stderr
