"""The report's radiosity tables say which storage of F their runs read (issue 17): the case lists pin the report's
dense float32, and a table of runs in other storages says which, with their counts; Poisson's tables say nothing."""
import pandas as pd

from analysis.radiosity_tables import storage_note, threads_note


def frame(storages, precisions):
    return pd.DataFrame({"params.storage": storages, "params.ff_precision": precisions,
                         "params.threads": [2] * len(storages), "provenance.host": ["vm"] * len(storages)})


def test_dense_float32_runs_are_said_to_be_the_reports_storage():
    note = threads_note(frame(["dense", "dense"], ["float32", "float32"]))
    assert "the runner stopped at its cap). F as the report stored it, dense float32, in every run" in note


def test_other_storages_are_named_with_their_counts():
    note = storage_note(frame(["csr", "dense", "csr"], ["float32", "float32", "float32"]))
    assert note == "F read as csr float32 (2 runs), dense float32 (1 runs)."


def test_records_without_form_factors_get_no_storage_note():
    df = pd.DataFrame({"params.threads": [2], "provenance.host": ["vm"]})
    assert storage_note(df) == ""
    assert threads_note(df) == ("Ours: median [95% interval of the median] n=runs, on vm with 2 OpenMP thread(s); "
                                "capped: the interval is not within +-5% of the median (or the runner stopped at its "
                                "cap). No record left out.")
