"""python -m analysis [PRESET]: every table and plot from the records of PRESET (default: quick)."""
import sys

from analysis import table41
from analysis.records import RESULTS


def main():
    preset = sys.argv[1] if len(sys.argv) > 1 else "quick"
    tables, plots = RESULTS / "tables", RESULTS / "plots"
    t = table41.write(preset, tables, plots)
    print(f"analysis: table41 ({preset}): {'no records' if t is None else f'{len(t)} rows'} -> {tables}, {plots}")


if __name__ == "__main__":
    main()
