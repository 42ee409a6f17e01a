"""Radiosity across MPI ranks in the sparse storages (issue 17), through the real program under mpirun: csr,
compressed and runs built by each rank from its rows of the dense file give backend serial's answer, rows balanced
by entries (or by cost, for runs); --storage auto chooses alike on any number of ranks; the memory check counts the
sparse storage; a sparse file is refused. The dense storage's tests are in test_mpi_radiosity.py."""
import numpy as np
import pytest

from mpi_files import HEMICUBE, MPI_BUILT, form_factor_files, messages, radiosities, radiosity, record, rel_diff

pytestmark = pytest.mark.skipif(not MPI_BUILT, reason="bin/radiosity built without MPI, or no mpirun")


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    return form_factor_files(tmp_path_factory)


SPARSE = [("csr", "float32"), ("compressed", "float32"), ("compressed", "float16")]
RUNS = [("runs", "float32"), ("runs", "float16")]


@pytest.fixture(scope="module")
def serial_sparse(files):
    """Backend serial's answers in the sparse storages: 20 fixed Jacobi steps in float (AOS), and Jacobi and
    BiCG-STAB to 1e-6 (SOA)."""
    d, out = files
    answers = {}
    for storage, values in SPARSE + RUNS:
        for kind, args in (("steps", ["--steps", "20", "--layout", "aos", "--no-verify"]),
                           ("jacobi", ["--tol", "1e-6", "--layout", "soa"]),
                           ("bicgstab", ["--method", "bicgstab", "--tol", "1e-6", "--layout", "soa"])):
            o = d / f"serial-{storage}-{values}-{kind}.xml"
            rec = record(radiosity("solve", out["scene"], "--ff", out["serial"][0], "--backend", "serial",
                                   "--storage", storage, "--ff-precision", values, *args, "--output", o, "--json",
                                   "--quiet"))
            assert rec["params"]["storage"] == storage
            answers[storage, values, kind] = (rec, radiosities(o))
    return answers


def sparse_bytes_per_entry(storage, values):
    return (4 if values == "float32" else 2) + (4 if storage == "csr" else 2)


@pytest.mark.parametrize("ranks", [1, 2, 3, 4])
@pytest.mark.parametrize("storage,values", SPARSE)
def test_mpi_sparse_storage_gives_serial_answer_rows_balanced_by_entries(files, serial_sparse, ranks, storage, values,
                                                                          tmp_path):
    """Each rank builds its rows in csr or compressed from its rows of the dense file and runs the CPU's sparse
    product on them: fixed Jacobi steps are serial's bits (a row's sum is the same code on any rank, the float16
    scale every rank's largest value); to a tolerance, within 1e-6 (the dots add in another order). The ranks' rows
    are balanced by entries, and the record says the bytes of F each holds in that storage."""
    _, out = files
    writer = {1: 2, 2: 4, 3: 1, 4: 3}[ranks]
    o = tmp_path / "steps.xml"
    rec = record(radiosity("solve", out["scene"], "--ff", out[writer][0], "--backend", "mpi", "--storage", storage,
                           "--ff-precision", values, "--steps", "20", "--layout", "aos", "--no-verify", "--output", o,
                           "--json", "--quiet", np_=ranks))
    assert np.array_equal(radiosities(o), serial_sparse[storage, values, "steps"][1])
    assert rec["params"]["storage"] == storage
    n = rec["params"]["patches"]
    mpi = rec["mpi"]
    rows, held = mpi["rank_rows"], mpi["rank_ff_bytes"]
    assert sum(rows) == n and len(held) == ranks
    entries = [(b - 8 * (n + 1)) / sparse_bytes_per_entry(storage, values) for b in held]
    assert all(e == int(e) and e >= 0 for e in entries), entries
    # what one product reads on all ranks together: serial's entries of the same storage
    assert sum(entries) * sparse_bytes_per_entry(storage, values) + 8 * (n + 1) == pytest.approx(
        serial_sparse[storage, values, "steps"][0]["perf"]["matrix_bytes"])
    # balanced by entries (a row's cost: its entries and 8, csr_kernels.hpp), each block within one row of its share
    cost = [e + 8 * r for e, r in zip(entries, rows)]
    assert max(cost) <= sum(cost) / ranks + n + 8, (cost, rows)
    for method, layout in (("jacobi", "soa"), ("bicgstab", "soa")):
        o = tmp_path / f"{method}.xml"
        rec = record(radiosity("solve", out["scene"], "--ff", out[writer][0], "--backend", "mpi", "--storage", storage,
                               "--ff-precision", values, "--method", method, "--tol", "1e-6", "--layout", layout,
                               "--output", o, "--json", "--quiet", np_=ranks))
        ref, b_ref = serial_sparse[storage, values, method]
        assert rel_diff(radiosities(o), b_ref) <= 1e-6
        assert rec["result"]["status"] == "converged" and rec["verify"]["agreed"] is True


def runs_counts(held_32, held_16, n):
    """A runs matrix's stored values e and runs r from its bytes in float32 (4e + 4r + 16 (n + 1)) and in float16
    (2e + 4r + 16 (n + 1)): the same rows, the same runs."""
    e = (held_32 - held_16) / 2
    return e, (held_16 - 16 * (n + 1) - 2 * e) / 4


@pytest.mark.parametrize("ranks", [1, 2, 3, 4])
def test_mpi_runs_storage_gives_serial_answer_rows_balanced_by_cost(files, serial_sparse, ranks, tmp_path):
    """Each rank builds its rows in runs storage from its rows of the dense file (row and run starts for every row,
    its own rows' runs as the whole matrix's) and runs the CPU's runs product on them: a row's sum depends only on
    its runs, so fixed Jacobi steps are serial's bits in float32 and float16 (the float16 scale every rank's largest
    value); to a tolerance, within 1e-6. The ranks' rows are balanced by their cost (stored values, 8 a run, 8 a
    row), and the bytes each holds add up to serial's."""
    _, out = files
    writer = {1: 4, 2: 3, 3: 2, 4: 1}[ranks]
    held = {}
    for _, values in RUNS:
        o = tmp_path / f"steps-{values}.xml"
        rec = record(radiosity("solve", out["scene"], "--ff", out[writer][0], "--backend", "mpi", "--storage", "runs",
                               "--ff-precision", values, "--steps", "20", "--layout", "aos", "--no-verify",
                               "--output", o, "--json", "--quiet", np_=ranks))
        assert np.array_equal(radiosities(o), serial_sparse["runs", values, "steps"][1]), values
        assert rec["params"]["storage"] == "runs" and rec["params"]["ff_precision"] == values
        held[values] = rec["mpi"]["rank_ff_bytes"]
        rows = rec["mpi"]["rank_rows"]
    n = rec["params"]["patches"]
    assert sum(rows) == n and len(rows) == ranks
    counts = [runs_counts(a, b, n) for a, b in zip(held["float32"], held["float16"])]
    assert all(e == int(e) and r == int(r) and e >= 0 and r >= 0 for e, r in counts), counts
    # what one product reads on all ranks together: serial's runs matrix
    for values, v in (("float32", 4), ("float16", 2)):
        assert sum(e * v + 4 * r for e, r in counts) + 16 * (n + 1) == pytest.approx(
            serial_sparse["runs", values, "steps"][0]["perf"]["matrix_bytes"])
    # each block within one row of its share (a row: at most n values in at most n/6 + 1 runs: gaps above 4 zeros)
    cost = [e + 8 * r + 8 * rows_r for (e, r), rows_r in zip(counts, rows)]
    assert max(cost) <= sum(cost) / ranks + n + 8 * (n // 6 + 1) + 8, (cost, rows)
    for method in ("jacobi", "bicgstab"):
        o = tmp_path / f"{method}.xml"
        rec = record(radiosity("solve", out["scene"], "--ff", out[writer][0], "--backend", "mpi", "--storage", "runs",
                               "--ff-precision", "float16", "--method", method, "--tol", "1e-6", "--layout", "soa",
                               "--output", o, "--json", "--quiet", np_=ranks))
        assert rel_diff(radiosities(o), serial_sparse["runs", "float16", method][1]) <= 1e-6
        assert rec["result"]["status"] == "converged" and rec["verify"]["agreed"] is True


def test_mpi_auto_chooses_alike_on_any_number_of_ranks(files):
    """--storage auto on mpi chooses from every rank's counts together (runs counted in each rank's rows and summed):
    the serial run's storage on 1 and 3 ranks, on scene1 (36% of F non-zero) runs, as the summary says."""
    _, out = files
    picks = []
    for np_, backend in ((None, "serial"), (1, "mpi"), (3, "mpi")):
        p = radiosity("solve", out["scene"], "--ff", out["serial"][0], "--backend", backend, "--steps", "2",
                      "--no-verify", "--json", np_=np_)
        rec = record(p)
        assert rec["params"]["storage_requested"] == "auto"
        picks.append(rec["params"]["storage"])
        assert f"form factors: {picks[-1]} (auto: the fewest bytes per step" in p.stdout, p.stdout
    assert picks == ["runs"] * 3, picks


@pytest.mark.parametrize("storage,values", [("csr", "float32"), ("runs", "float32"), ("runs", "float16")])
def test_mpi_memory_check_counts_the_sparse_storage(files, tmp_path, storage, values):
    """--max-memory-per-rank with csr or runs: what a rank needs (the record's rank_need_bytes, counted before the
    matrix is built) is its dense rows while its matrix is built, that matrix (the bytes it then holds:
    rank_ff_bytes) and the vectors; a byte less is refused on every rank with one line, exit 2."""
    _, out = files
    args = ["solve", out["scene"], "--ff", out["serial"][0], "--backend", "mpi", "--storage", storage,
            "--ff-precision", values, "--steps", "2", "--no-verify", "--json", "--quiet"]
    mpi = record(radiosity(*args, np_=2))["mpi"]
    need = mpi["rank_need_bytes"]
    n = sum(mpi["rank_rows"])
    vectors = (2 * (8 + 2) * 3 * 8 + 8 * 3 * 8) * n  # solve_load.cpp's vector_bytes
    assert need == [f + 4 * r * n + vectors for f, r in zip(mpi["rank_ff_bytes"], mpi["rank_rows"])], mpi
    ok = record(radiosity(*args, "--max-memory-per-rank", str(int(max(need))), np_=2))
    assert ok["mpi"]["rank_need_bytes"] == need
    p = radiosity(*args, "--max-memory-per-rank", str(int(max(need)) - 1), np_=2)
    assert p.returncode == 2, p.stderr
    lines = messages(p)
    assert len(lines) == 1 and f"in {storage} {values}" in lines[0], lines
    assert "more than --max-memory-per-rank" in lines[0], lines


def test_mpi_refuses_a_sparse_file(files, tmp_path):
    _, out = files
    f = tmp_path / "csr.ff"
    record(radiosity("formfactors", out["scene"], *HEMICUBE, "-o", f, "--storage", "csr", "--json", "--quiet"))
    p = radiosity("solve", out["scene"], "--ff", f, "--backend", "mpi", "--steps", "2", np_=2)
    assert p.returncode == 2 and "each rank builds its rows' storage" in p.stderr, p.stderr
