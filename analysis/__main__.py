"""python -m analysis tables|report|audit PRESET [--sample N]

  tables  every table (results/tables/*.csv, *.md) and plot (results/plots/*.png) from the records of PRESET
  report  the reproduced report, report/REPORT-<preset>.md (run `tables` first; make report does)
  audit   re-runs a sample of PRESET's recorded cases here and compares outcome and time with the records"""
import argparse
import sys

from analysis import accuracy, audit, figure42, mpi_radiosity, radiosity_tables, report, table41, table42_audit


def main():
    ap = argparse.ArgumentParser(prog="python -m analysis", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("command", choices=["tables", "report", "audit"])
    ap.add_argument("preset", nargs="?", default="quick")
    ap.add_argument("--sample", type=int, default=5, help="audit: how many recorded cases to re-run")
    a = ap.parse_args()
    if a.command == "tables":
        made = {"table41": table41.write_table(a.preset), **radiosity_tables.write_all(a.preset),
                "figure42": figure42.write(a.preset), **accuracy.write_all(a.preset),
                "mpi_radiosity": mpi_radiosity.write_table(a.preset), "table42_audit": table42_audit.write(a.preset)}
        for name, out in made.items():
            print(f"analysis: {name} ({a.preset}): {'no records' if out is None else 'written'}")
        return 0
    if a.command == "report":
        print(f"analysis: wrote {report.write(a.preset)}")
        return 0
    return audit.run(a.preset, a.sample)


if __name__ == "__main__":
    sys.exit(main())
