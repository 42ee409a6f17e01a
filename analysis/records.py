"""Loading run records (JSON Lines) into flat pandas frames, and summarising repeats."""
import json
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "results"


def load(experiment, preset=None):
    """All records of an experiment (one preset, or every preset) as one flat frame: columns like 'params.n'."""
    files = sorted((RESULTS / experiment).glob(f"{preset or '*'}.jsonl"))
    rows = []
    for f in files:
        for line in f.read_text().splitlines():
            if line.strip():
                rec = json.loads(line)
                rec["file"] = str(f.relative_to(ROOT))
                rows.append(rec)
    return pd.json_normalize(rows) if rows else pd.DataFrame()


def paper_table(name):
    """The report's published numbers, transcribed once into results/paper/NAME.csv."""
    return pd.read_csv(RESULTS / "paper" / f"{name}.csv", comment="#")


def summarise(df, keys, value):
    """Median of `value` over repeats per `keys`, with min, max and the repeat count."""
    g = df.groupby(keys, dropna=False)[value]
    return g.agg(median="median", min="min", max="max", repeats="count").reset_index()
