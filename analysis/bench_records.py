"""The records of `make bench` (analysis.bench, analysis.bench_sparse): one machine's records, their medians and
intervals, and the bandwidth limit measured next to a case."""
import pandas as pd

from analysis.records import median_ci


def on_host(df, host):
    return df[df["provenance.host"] == host] if len(df) else df


def median_of(df, col):
    return float(df[col].median())


def ci_of(df, col, scale=1.0):
    """The bootstrap 95% interval of the median of df[col] (times scale), as "[lo, hi]"; empty below 3 repeats."""
    v = df[col].dropna() * scale
    return "[{:.3g}, {:.3g}]".format(*median_ci(v)) if len(v) >= 3 else ""


def limit_next_to(stream, recs, col="perf.triad_GBps"):
    """The bandwidth (the triad, or col) measured next to a case's records: the median of the last stream record at
    or before their first and the first at or after their last (either alone where the other is missing)."""
    t, first, last = stream["provenance.utc"], recs["provenance.utc"].min(), recs["provenance.utc"].max()
    near = [s for s in (stream[t <= first].sort_values("provenance.utc").tail(1),
                        stream[t >= last].sort_values("provenance.utc").head(1)) if len(s)]
    return median_of(pd.concat(near), col)
