"""One quantity, one number (issues 31 and 34): every table that quotes a quantity another table quotes too (room3's
cold Jacobi solve in Tables 4.2, 4.3 and the relighting table) registers it here with its interval and its settings;
`check` fails, naming both places, when two quotes of one quantity under the same settings disagree beyond their
intervals. `python -m analysis tables` saves the quotes beside the tables (tables/quotes_<preset>.json), and
`python -m analysis report` checks them before it writes a word."""
import json
import math

from analysis.records import tables_dir, writing

_quotes = []
# The settings that make two quotes of a quantity the same measurement: where any differs, the quotes say so.
SETTINGS = ("params.threads", "params.hemicube", "params.weights", "params.tol", "params.storage",
            "params.ff_precision", "params.precision", "params.layout", "params.backend", "params.method")


class Disagreement(ValueError):
    """Two quotes of one quantity under the same settings whose intervals do not overlap."""


def settings_of(df):
    """The settings of the runs behind a quote, as text per key (sorted distinct values)."""
    out = {}
    for k in SETTINGS:
        if k in df:
            vals = sorted({f"{v:g}" if isinstance(v, (int, float)) and not isinstance(v, bool) else str(v)
                           for v in df[k].dropna()})
            out[k] = ", ".join(vals) if vals else "default"
    for k, before in (("params.storage", "dense"), ("params.ff_precision", "float32")):  # records from before them
        if out.get(k, "default") == "default" and ("params.backend" in df or "params.scene" in df):
            out[k] = before
    return out


def quote(quantity, where, runs, df):
    """Registers a quote of `quantity` at `where` (table and cell): its median and 95% interval over `runs` (min and
    max where fewer than 3, and then never held against another quote), with the settings of df's records. Nothing
    while another machine is read."""
    if not writing() or len(runs) == 0:
        return
    from analysis.records import median_ci
    v = sorted(float(x) for x in runs)
    lo, hi = median_ci(v) if len(v) >= 3 else (v[0], v[-1])
    _quotes.append({"quantity": quantity, "where": where, "median": v[len(v) // 2] if len(v) % 2 else
                    (v[len(v) // 2 - 1] + v[len(v) // 2]) / 2, "low": float(lo), "high": float(hi), "n": len(v),
                    "settings": settings_of(df)})


def reset():
    _quotes.clear()


def save(preset, kind="quotes"):
    """tables/<kind>_<preset>.json: `tables` writes quotes_, `python -m analysis.bench` (make bench) bench_quotes_."""
    tables_dir().mkdir(parents=True, exist_ok=True)
    path = tables_dir() / f"{kind}_{preset}.json"
    path.write_text(json.dumps(_quotes, indent=1, sort_keys=True) + "\n")
    return path


def load(preset):
    """Every quote saved for this preset: the tables' and make bench's."""
    out = []
    for kind in ("quotes", "bench_quotes"):
        path = tables_dir() / f"{kind}_{preset}.json"
        out += json.loads(path.read_text()) if path.exists() else []
    return out


def check(quotes):
    """Raises Disagreement naming both places of every pair of quotes of one quantity under the same settings whose
    intervals do not overlap; returns the pairs whose settings differ (to be stated) or that have fewer than 3
    runs (not checked), as text."""
    differ, wrong = [], []
    for i, a in enumerate(quotes):
        for b in quotes[i + 1:]:
            if a["quantity"] != b["quantity"]:
                continue
            diff = {k for k in set(a["settings"]) | set(b["settings"])
                    if a["settings"].get(k) != b["settings"].get(k)}
            if diff:
                differ.append(f"{a['quantity']}: {a['where']} and {b['where']} differ in " +
                              ", ".join(f"{k[len('params.'):]} ({a['settings'].get(k)} against "
                                        f"{b['settings'].get(k)})" for k in sorted(diff)))
                continue
            if min(a["n"], b["n"]) < 3:  # no interval of the median to hold them to
                differ.append(f"{a['quantity']}: {a['where']} and {b['where']} not checked (fewer than 3 runs)")
                continue
            if a["high"] < b["low"] or b["high"] < a["low"]:
                wrong.append(f"{a['quantity']} is {fmt(a)} in {a['where']} but {fmt(b)} in {b['where']}, under "
                             "the same settings: one quantity, two numbers")
    if wrong:
        raise Disagreement(f"{len(wrong)} disagreement(s): " + "; ".join(wrong))
    return differ


def fmt(q):
    g = lambda x: f"{x:.4g}" if math.isfinite(x) else "nan"  # noqa: E731
    return f"{g(q['median'])} [{g(q['low'])}, {g(q['high'])}] (n = {q['n']})"
