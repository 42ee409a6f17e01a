"""relight's light basis on any backend with a k-right-hand-side product (issue 36, item 3): --backend mpi under
mpirun -np 2 writes the basis openmp writes, within 1e-6 relative, and serves the same frames; a frame that changes
a reflectivity is refused there in one line; a backend without a k-product (the GPU backends, original) is refused
in one line with exit status 2 before anything is read or a device is asked for."""
import json
import struct

import numpy as np
import pytest

from conftest import BIN, ROOT, run
from mpi_files import MPI_BUILT, messages, radiosity, record

SCENE1 = ROOT / "radiosity" / "scenes" / "scene1.xml"
SCENE2 = ROOT / "radiosity" / "scenes" / "scene2.xml"


def read_basis(path):
    """The k × n × 3 float64 of a basis file (basis_file.hpp), light after light."""
    b = path.read_bytes()
    k, n = struct.unpack_from("<IQ", b, 12)
    return np.frombuffer(b[len(b) - 8 - 24 * k * n:len(b) - 8], dtype="<f8").reshape(k, n, 3)


def rel_diff(a, b):
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


@pytest.fixture(scope="module")
def ff(tmp_path_factory):
    d = tmp_path_factory.mktemp("relight-mpi")
    f = d / "scene2.ff"
    record(radiosity("formfactors", SCENE2, "-o", f, "--hemicube", "32", "--json", "--quiet"))
    return d, f


@pytest.fixture(scope="module")
def ff1(tmp_path_factory):
    d = tmp_path_factory.mktemp("relight-mpi-1")
    f = d / "scene1.ff"
    record(radiosity("formfactors", SCENE1, "-o", f, "--hemicube", "32", "--json", "--quiet"))
    return d, f


def relight(scene, f, *args, np_=None):
    return radiosity("relight", scene, "--ff", f, "--random-frames", "4", "--seed", "7", "--record-patches", "400",
                     "--json", "--quiet", *map(str, args), np_=np_)


# scene2: two lights (the k-product over row blocks, k = 2); scene1: one light (k = 1); 3 ranks: an uneven split.
@pytest.mark.skipif(not MPI_BUILT, reason="bin/radiosity built without MPI, or no mpirun")
@pytest.mark.parametrize("scene,lights,ranks", [("scene2", 2, 2), ("scene2", 2, 3), ("scene1", 1, 2)])
def test_mpi_basis_and_frames_equal_openmp_within_1e6(ff, ff1, scene, lights, ranks):
    d, f = ff if scene == "scene2" else ff1
    path = SCENE2 if scene == "scene2" else SCENE1
    omp = record(relight(path, f, "--backend", "openmp", "--threads", "2", "--basis", d / f"omp{ranks}.basis"))
    mpi = record(relight(path, f, "--backend", "mpi", "--basis", d / f"mpi{ranks}.basis", np_=ranks))
    assert mpi["params"]["backend"] == "mpi" and mpi["provenance"]["mpi_ranks"] == ranks
    assert not omp["result"]["basis"]["loaded"] and not mpi["result"]["basis"]["loaded"]
    assert mpi["result"]["basis"]["max_residual"] <= 1e-7
    a, b = read_basis(d / f"mpi{ranks}.basis"), read_basis(d / f"omp{ranks}.basis")
    assert a.shape == b.shape and a.shape[0] == lights
    assert rel_diff(a, b) <= 1e-6
    assert abs(mpi["result"]["basis"]["iterations"] - omp["result"]["basis"]["iterations"]) <= 1
    frames = [(np.array(x["radiosity"]), np.array(y["radiosity"]))
              for x, y in zip(mpi["result"]["per_frame"], omp["result"]["per_frame"])]
    assert len(frames) == 4 and all(x.shape == (400, 3) for x, _ in frames)
    assert max(rel_diff(x, y) for x, y in frames) <= 1e-6


@pytest.mark.skipif(not MPI_BUILT, reason="bin/radiosity built without MPI, or no mpirun")
def test_mpi_refuses_a_reflectivity_frame_in_one_line(ff):
    d, f = ff
    frames = d / "refl.json"
    frames.write_text(json.dumps({"frames": [{"reflectivity": {"room.1": [0.5, 0.5, 0.5]}}]}))
    p = radiosity("relight", SCENE2, "--ff", f, "--frames", frames, "--backend", "mpi", "--quiet", np_=2)
    assert p.returncode == 2, p.stderr
    assert len(messages(p)) == 1 and "frame 0 changes a reflectivity" in messages(p)[0], p.stderr


@pytest.mark.skipif(not MPI_BUILT, reason="bin/radiosity built without MPI, or no mpirun")
def test_bench_rhs_is_refused_on_mpi(ff):
    _, f = ff
    p = radiosity("relight", SCENE2, "--ff", f, "--bench-rhs", "2", "--passes", "1", "--backend", "mpi", "--quiet",
                  np_=2)
    assert p.returncode == 2 and p.stdout == "", p.stdout
    assert len(messages(p)) == 1 and "--bench-rhs times one process's" in messages(p)[0], p.stderr


@pytest.mark.parametrize("backend", ["cuda", "cublas", "hybrid", "original"])
def test_a_backend_without_a_k_product_is_refused_in_one_line(ff, backend):
    d, f = ff
    basis = d / f"{backend}.basis"
    p = run([BIN / "radiosity", "relight", SCENE2, "--ff", f, "--random-frames", "2", "--backend", backend,
             "--basis", basis])
    assert p.returncode == 2 and p.stdout == "", (p.stdout, p.stderr)
    lines = p.stderr.splitlines()
    assert len(lines) == 1, lines
    # a build without CUDA says so first (require_backend); with it, the refusal comes before any device is asked for
    assert (f"relight: --backend {backend} has no k-right-hand-side product (the light basis runs on serial, openmp"
            in lines[0]) or "this build has no CUDA" in lines[0], lines
    assert not basis.exists()


@pytest.mark.parametrize("ranks", [None, 2])
def test_an_unreachable_basis_tol_is_refused_in_one_line(ff, ranks):
    if ranks and not MPI_BUILT:
        pytest.skip("bin/radiosity built without MPI, or no mpirun")
    _, f = ff
    p = radiosity("relight", SCENE2, "--ff", f, "--random-frames", "1", "--basis-tol", "1e-300", "--quiet",
                  *(["--backend", "mpi"] if ranks else []), np_=ranks)
    assert p.returncode == 2 and p.stdout == "", p.stdout
    assert len(messages(p)) == 1 and "--basis-tol" in messages(p)[0] and "double" in messages(p)[0], p.stderr
