"""The shape of the code that issue 15 asked for, kept: no function of the app layer (radiosity/app/) longer than 80
lines, as lizard counts a function's length (its first line to its last)."""
from pathlib import Path

import lizard

ROOT = Path(__file__).resolve().parents[2]


def test_no_app_function_is_longer_than_80_lines():
    files = sorted((ROOT / "radiosity" / "app").glob("*.cpp"))
    assert len(files) > 10
    long = [f"{f.relative_to(ROOT)}:{fn.start_line} {fn.name} ({fn.length} lines)"
            for f in files for fn in lizard.analyze_file(str(f)).function_list if fn.length > 80]
    assert not long, long
