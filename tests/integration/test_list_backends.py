"""--list-backends [--json] of bin/poisson and bin/radiosity: the facts the Python reads (common/backend_facts.py)
agree with what the programs do: the names their --help lists, the vectors per iteration and the default iteration
limit that a run records, the GPU backends that refuse where there is no GPU in the same way."""
import json
import sys

import pytest

from conftest import BIN, ROOT, poisson, run

sys.path.insert(0, str(ROOT))
from common import backend_facts  # noqa: E402


def listed(program):
    p = run([BIN / program, "--list-backends", "--json"])
    assert p.returncode == 0 and p.stderr == "", p.stderr
    return json.loads(p.stdout)


@pytest.mark.parametrize("program", ["poisson", "radiosity"])
def test_the_json_names_every_backend_once_with_its_facts(program):
    j = listed(program)
    assert j["program"] == program
    names = [b["name"] for b in j["backends"]]
    assert len(names) == len(set(names)) >= 6
    for b in j["backends"]:
        assert isinstance(b["gpu"], bool) and isinstance(b["built"], bool), b
        assert (b["why_not"] == "") == b["built"], b
    text = run([BIN / program, "--list-backends"]).stdout
    assert [l.split()[0] for l in text.splitlines()[1:len(names) + 1]] == names
    assert backend_facts.load() == {p: listed(p) for p in backend_facts.PROGRAMS}


def test_poisson_lists_what_its_help_lists_and_the_gpu_ones_are_the_cuda_ones():
    j = listed("poisson")
    help_text = run([BIN / "poisson", "--help"]).stdout
    backends_part = help_text[help_text.index("Backends:"):help_text.index("Examples:")]
    assert [l.split()[0] for l in backends_part.splitlines()[1:] if l.strip()] == [b["name"] for b in j["backends"]]
    assert {b["name"] for b in j["backends"] if b["gpu"]} == {"cublas1", "cublas2", "cuda"}
    assert j["default_max_iter"]["floor"] == 1000 and j["default_max_iter"]["per_n"] == 4


@pytest.mark.parametrize("backend", ["serial", "openmp"])
@pytest.mark.parametrize("variant", [None, "classic", "onesweep"])
def test_poisson_records_the_vectors_and_the_iteration_limit_it_lists(backend, variant):
    b = backend_facts.backends("poisson")[backend]
    args = ["--n", "40", "--backend", backend] + (["--variant", variant] if variant else [])
    p, r = poisson(*args)
    if variant and variant not in b["variants"]:
        assert p.returncode == 2, p.stderr
        return
    assert p.returncode == 0, p.stderr
    assert r["params"]["variant"] == (variant or b["default_variant"]["double"])
    assert r["perf"]["vectors_per_iteration"] == backend_facts.poisson_vectors(backend, variant)
    assert r["params"]["max_iter"] == backend_facts.poisson_default_max_iter(40)
    p, r = poisson("--n", "300", "--backend", backend, "--steps", "1")
    assert r["params"]["max_iter"] == 1  # fixed steps: the limit is the steps
    p, r = poisson("--n", "300", "--backend", backend, "--tol", "0.9")
    assert r["params"]["max_iter"] == backend_facts.poisson_default_max_iter(300) == 1200


def test_radiosity_lists_the_backends_its_solve_accepts():
    j = listed("radiosity")
    help_text = run([BIN / "radiosity", "solve", "--help"]).stdout
    for b in j["backends"]:
        assert b["name"] in help_text
    assert {b["name"] for b in j["backends"] if b["gpu"]} == {"cuda", "cublas", "hybrid"}
    assert [b["name"] for b in j["backends"] if b["distributed"]] == ["mpi"]
    assert backend_facts.gpu_backends() == ["cublas", "cublas1", "cublas2", "cuda", "hybrid"]


def test_the_kit_plan_reads_the_facts_not_a_copy():
    from gpukit import cases, plan
    c = cases.Case("table41", 0, "bin/poisson --backend cublas2 --n 1024 --max-iter 100000")
    assert c.is_gpu() and not cases.Case("table41", 1, "bin/poisson --backend openmp --n 64").is_gpu()
    n = 1024
    assert plan.case_estimate(c) == round(1 + 1581 * n / 1024 * 16 * 8 * n * n / plan.BYTES_PER_S)


def test_the_cuda_libraries_each_backend_lists_are_what_the_gpu_kit_skips_it_without():
    """"libraries": the CUDA libraries a backend calls (cuBLAS: poisson's cublas1 and cublas2 and radiosity's cublas;
    cuSPARSE: radiosity's cuda and cublas for csr float32 F), the facts by which the kit's plan skips a step on a node
    that lacks one (gpukit/plan.py needs_of)."""
    libs = {(p, b["name"]): b["libraries"] for p in backend_facts.PROGRAMS for b in listed(p)["backends"]}
    assert {k: v for k, v in libs.items() if v} == {("poisson", "cublas1"): ["cublas"],
                                                    ("poisson", "cublas2"): ["cublas"],
                                                    ("radiosity", "cuda"): ["cusparse"],
                                                    ("radiosity", "cublas"): ["cublas", "cusparse"]}
    from gpukit.plan import needs_of
    assert needs_of(["bin/poisson", "--backend", "cublas2", "--n", "64"]) == {"cublas"}
    assert needs_of(["bin/poisson", "--backend", "cuda", "--n", "64"]) == set()
    solve = ["bin/radiosity", "solve", "s.xml", "--ff", "s.ff"]
    assert needs_of(solve + ["--backend", "cuda", "--storage", "csr"]) == {"cusparse"}
    assert needs_of(solve + ["--backend", "cuda", "--storage", "csr", "--precision", "double"]) == set()
    assert needs_of(solve + ["--backend", "cublas", "--storage", "dense"]) == {"cublas"}
    assert needs_of(solve + ["--backend", "hybrid", "--storage", "csr"]) == set()
