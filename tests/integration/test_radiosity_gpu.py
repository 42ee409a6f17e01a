"""bin/radiosity solve on the GPU backends (cuda, cublas with and without --fused, hybrid): agreement with the
float64 reference through the real program and the record's device times, where a GPU is present; and on every
machine the refusals: a GPU backend without a GPU, a distribution outside [0, 1], hybrid with BiCG-STAB, an option
given to a backend it does not belong to. Each ends with exit status 2 and one line."""
import json
import xml.etree.ElementTree as ET

import pytest

from conftest import BIN, ROOT, built_backends, gpu_absent_reason, run

SCENES = ROOT / "radiosity" / "scenes"

# The dense product of each backend (--storage dense: auto would take a sparse storage on cuda and cublas), and the
# sparse storages on cuda and cublas: csr float32 by cuSPARSE, the others by our warp-per-row kernel.
GPU_RUNS = {
    "cuda": ["--backend", "cuda", "--storage", "dense"],
    "cublas": ["--backend", "cublas", "--storage", "dense"],
    "cublas-fused": ["--backend", "cublas", "--fused", "--storage", "dense"],
    "hybrid-0": ["--backend", "hybrid", "--distribution", "0"],
    "hybrid-0.3": ["--backend", "hybrid", "--distribution", "0.3"],
    "hybrid-0.3-overlap": ["--backend", "hybrid", "--distribution", "0.3", "--overlap"],
    "hybrid-1": ["--backend", "hybrid", "--distribution", "1"],
    "cuda-csr": ["--backend", "cuda", "--storage", "csr"],
    "cuda-compressed": ["--backend", "cuda", "--storage", "compressed"],
    "cuda-compressed-float16": ["--backend", "cuda", "--storage", "compressed", "--ff-precision", "float16"],
    "cublas-csr": ["--backend", "cublas", "--storage", "csr"],
    "cublas-compressed-bfloat16": ["--backend", "cublas", "--storage", "compressed", "--ff-precision", "bfloat16"],
}


def radiosity(*args, timeout=600):
    return run([BIN / "radiosity", *args], timeout=timeout)


@pytest.fixture(scope="module")
def scene1(tmp_path_factory):
    d = tmp_path_factory.mktemp("scene1_gpu")
    ff = d / "scene1.ff"
    p = radiosity("formfactors", SCENES / "scene1.xml", "-o", ff, "--hemicube", "64", "--quiet")
    assert p.returncode == 0, p.stderr
    return d, ff


def solve(scene1, *args):
    return radiosity("solve", SCENES / "scene1.xml", "--ff", scene1[1], *args)


def record(p):
    assert p.returncode == 0, p.stderr
    return json.loads([l for l in p.stdout.splitlines() if l.startswith("{")][-1])


def radiosities(path):
    return [t.get("radiosity") for t in ET.parse(path).getroot().iter("triangle")]


def one_line_exit_2(p):
    assert p.returncode == 2, (p.returncode, p.stderr)
    assert len(p.stderr.strip().splitlines()) == 1, p.stderr
    return p.stderr


# --- with a GPU ---------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("precision", ["float", "double"])
@pytest.mark.parametrize("name", sorted(GPU_RUNS))
def test_gpu_backend_agrees_with_the_float64_reference(scene1, requires_gpu, name, precision):
    rec = record(solve(scene1, *GPU_RUNS[name], "--steps", "32", "--precision", precision, "--json", "--quiet"))
    assert rec["result"]["status"] == "steps_done" and rec["result"]["iterations"] == 32
    assert rec["verify"]["agreed"] is True, rec["verify"]
    assert rec["backend_info"]["gpu"]
    times = rec["times_s"]
    for key in ("upload", "transfer", "device_compute", "host_compute"):
        assert times[key] >= 0, key
    assert times["upload"] <= times["setup"]
    assert rec["perf"]["transfer_bytes"] >= 0
    if "--distribution" in GPU_RUNS[name]:
        assert rec["params"]["distribution"] == float(GPU_RUNS[name][GPU_RUNS[name].index("--distribution") + 1])
        assert rec["params"]["overlap"] == ("--overlap" in GPU_RUNS[name])


@pytest.mark.parametrize("name", ["cuda", "cublas", "cublas-fused", "cuda-csr", "cublas-csr", "cuda-compressed"])
def test_gpu_bicgstab_converges_and_agrees(scene1, requires_gpu, name):
    rec = record(solve(scene1, *GPU_RUNS[name], "--method", "bicgstab", "--tol", "1e-6", "--json", "--quiet"))
    assert rec["result"]["status"] == "converged", rec["result"]
    assert rec["verify"]["agreed"] is True, rec["verify"]


def test_cublas_runs_soa_without_being_told(scene1, requires_gpu):
    rec = record(solve(scene1, "--backend", "cublas", "--steps", "2", "--json", "--quiet"))
    assert rec["params"]["layout"] == "soa"


def test_hybrid_ends_write_what_openmp_and_cuda_write(scene1, requires_gpu, tmp_path):
    out = {}
    for name, args in {"openmp": ["--backend", "openmp", "--storage", "dense"], "cuda": GPU_RUNS["cuda"],
                       "hybrid-0": GPU_RUNS["hybrid-0"], "hybrid-1": GPU_RUNS["hybrid-1"]}.items():
        path = tmp_path / f"{name}.xml"
        p = solve(scene1, *args, "--steps", "32", "--threads", "2", "--output", path, "--quiet")
        assert p.returncode == 0, p.stderr
        out[name] = radiosities(path)
    assert out["hybrid-0"] == out["openmp"]
    assert out["hybrid-1"] == out["cuda"]


@pytest.mark.parametrize("gpu,cpu", [("cuda-csr", "aos"), ("cublas-csr", "soa"), ("cuda-compressed", "aos")])
def test_gpu_sparse_storage_gives_the_cpu_csr_answer(scene1, requires_gpu, tmp_path, gpu, cpu):
    """The sparse products (cuSPARSE for csr float32, ours for compressed) against serial's csr, 32 Jacobi steps in
    float: other summation orders, so within 1e-6 relative, not bits; the record names the product."""
    out = {}
    for name, args in {"cpu": ["--backend", "serial", "--storage", "csr", "--layout", cpu], "gpu": GPU_RUNS[gpu]}.items():
        path = tmp_path / f"{name}.xml"
        rec = record(solve(scene1, *args, "--steps", "32", "--output", path, "--json", "--quiet", "--no-verify"))
        out[name] = [[float(c) for c in r.split(",")] for r in radiosities(path)]
    assert rec["params"]["storage"] == GPU_RUNS[gpu][GPU_RUNS[gpu].index("--storage") + 1]
    assert ("cusparse" in rec["backend_info"]["product"]) == (gpu.endswith("-csr")), rec["backend_info"]
    worst = max(abs(a - b) for ra, rb in zip(out["gpu"], out["cpu"]) for a, b in zip(ra, rb))
    scale = max(abs(b) for rb in out["cpu"] for b in rb)
    assert worst <= 1e-6 * scale, (worst, scale)


# --- on every machine ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("backend", ["cuda", "cublas", "hybrid"])
def test_gpu_backend_without_gpu_exits_2_with_one_line(scene1, backend):
    if gpu_absent_reason() is None:
        pytest.skip("a GPU is present: this test checks the refusal on machines without one")
    err = one_line_exit_2(solve(scene1, "--backend", backend, "--steps", "4"))
    assert "needs an NVIDIA GPU" in err or "not available" in err, err


@pytest.mark.parametrize("d", ["1.5", "-0.1", "nan"])
def test_distribution_outside_0_1_exits_2(scene1, d):
    err = one_line_exit_2(solve(scene1, "--backend", "hybrid", "--distribution", d, "--steps", "4"))
    if "cuda" in built_backends():
        assert "distribution must be in [0, 1]" in err, err


def test_hybrid_refuses_bicgstab(scene1):
    err = one_line_exit_2(solve(scene1, "--backend", "hybrid", "--method", "bicgstab", "--tol", "1e-6"))
    if "cuda" in built_backends():
        assert "does not run method 'bicgstab'" in err, err


@pytest.mark.parametrize("args", [["--backend", "openmp", "--fused"], ["--backend", "cuda", "--overlap"],
                                  ["--backend", "cublas", "--distribution", "0.5"]])
def test_option_of_another_backend_exits_2(scene1, args):
    err = one_line_exit_2(solve(scene1, *args, "--steps", "4"))
    assert "applies to --backend" in err, err
