"""python -m analysis tables|report|machines PRESET [--machine LABEL] [--all-records]

  tables  every table (results/<machine>/tables/*.csv, *.md) and plot (results/<machine>/plots/*.png) from the
          machine's records of PRESET, beside the report's numbers and the reference machine's
  report  the reproduced report, report/<machine>/REPORT-<preset>.md (run `tables` first; make report does)
  machines  report/MACHINES.md, every machine with records side by side (make machines: asked for, never written
          by a machine's own make reproduce or make report)

The machine is --machine, else $MACHINE, else this machine's own label (common/machine_label.py). Records from a
dirty tree or from a commit not in this repository are left out, and counted under each table (--all-records keeps
them, for a developer's look). Exit 1 when a record does not validate, or when one quantity quoted by two tables
under the same settings disagrees beyond their intervals (analysis/consistency.py: both places are named, and
`report` then writes nothing)."""
import argparse
import re
import sys

from analysis import accuracy, consistency, figure42, machines, mpi_radiosity, poisson_methods, protocol, radiosity_tables, \
    records, relight, report, table41, table42_audit


def main():
    ap = argparse.ArgumentParser(prog="python -m analysis", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("command", choices=["tables", "report", "machines"])
    ap.add_argument("preset", nargs="?", default="quick")
    ap.add_argument("--machine", help="whose records (default: $MACHINE, else this machine)")
    ap.add_argument("--all-records", action="store_true",
                    help="also use records from dirty trees and unknown commits, and disturbed runs (left out by "
                         "default; never for committed tables)")
    a = ap.parse_args()
    if not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9_-]{0,63}", a.preset or ""):  # a name, never a path or markup
        print(f"analysis: {a.preset!r} is no preset: letters, digits, '-' and '_' (quick, paper, ci)", file=sys.stderr)
        return 2
    protocol.include_all(a.all_records)
    try:
        if a.machine:
            records.use(a.machine)
        label = records.machine()
    except ValueError as e:
        print(f"analysis: {e}", file=sys.stderr)
        return 2
    if a.command == "tables":
        consistency.reset()
        if not records.machine_dir().is_dir():
            known = ", ".join(records.machines()) or "none"
            print(f"analysis: no records of machine {label} in {records.RESULTS} (machines with records: {known}); "
                  "tables are written for the machines' own records only", file=sys.stderr)
        made = {**table41.write_table(a.preset), **poisson_methods.write_table(a.preset), **radiosity_tables.write_all(a.preset),
                "figure42": figure42.write(a.preset), **accuracy.write_all(a.preset),
                "mpi_radiosity": mpi_radiosity.write_table(a.preset), "table42_audit": table42_audit.write(a.preset)}
        made.update(relight.write_all(a.preset))
        consistency.save(a.preset)
        for name, out in made.items():
            print(f"analysis: {name} ({a.preset}, {label}): {'no records' if out is None else 'written'}")
            if out is None:  # a table of earlier records never stands in for one that has none now
                for f in (records.tables_dir() / f"{name}_{a.preset}.md", records.tables_dir() / f"{name}_{a.preset}.csv"):
                    f.unlink(missing_ok=True)
        if records.INVALID or protocol.BAD_STATE:  # reported where read; the tables were made without them
            files = sorted({f"{f}:{n}" for f, n, _ in records.INVALID})
            states = sorted({f"{f}:{n}" for f, n, _ in protocol.BAD_STATE})
            if files:
                print(f"analysis: {len(files)} record line(s) were no valid record (common/record.schema.json) and "
                      f"were left out: {', '.join(files[:20])}{' ...' if len(files) > 20 else ''}", file=sys.stderr)
            if states:
                print(f"analysis: {len(states)} state line(s) were no state line and were left out: "
                      f"{', '.join(states[:20])}{' ...' if len(states) > 20 else ''}", file=sys.stderr)
            return 1
        try:
            consistency.check(consistency.load(a.preset))
        except consistency.Disagreement as e:
            print(f"analysis: {e}", file=sys.stderr)
            return 1
        return 0
    if a.command == "machines":
        print(f"analysis: wrote {machines.write(a.preset)}")
        return 0
    try:
        consistency.check(consistency.load(a.preset))
    except consistency.Disagreement as e:
        print(f"analysis: no report written: {e}", file=sys.stderr)
        return 1
    print(f"analysis: wrote {report.write(a.preset)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
